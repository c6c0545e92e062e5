"""The plugin's server-manager XML agrees with the C++ classes (run by pvpython).

For every proxy of /work/main/Plugin/*.xml (STM_XML_DIR):
- the proxy and every property carry a non-empty <Documentation>;
- every filter is in the menu category "Spacetree Mesh"; the reader claims .nii and .nii.gz;
- every IntVectorProperty with command="SetX" has an XML default equal to GetX() of a fresh
  instance of the wrapped class (BodyLabels: empty XML default and GetNumberOfBodyLabels() == 0),
  its range domain equals the C++ clamp range, its enumeration the C++ enum;
- PrintSelf (str(obj)) of each class mentions every property;
- the proxies made by ParaView from these XML files hold the same defaults and push them
  unchanged into their VTK objects.
All mismatches are collected and reported together.
"""
import glob
import os
import xml.etree.ElementTree as ET

import spacetreemesh
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkDataSetAttributes
from vtkmodules.vtkIOImage import vtkNIFTIImageReader

import stmtesting as T

XML_DIR = T.env("STM_XML_DIR")
PLUGIN = T.env("STM_PLUGIN")
CATEGORY = "Spacetree Mesh"
EXPECTED_PROXIES = {
    ("filters", "stmImageToSpacetree"),
    ("filters", "stmSpacetreeBalance"),
    ("filters", "stmSpacetreeTessellate"),
    ("sources", "stmNIFTIReader"),
}
# Properties whose command is not a plain SetX/GetX pair, and what they are checked by instead.
SPECIAL = {"LabelArray", "Input", "FileName", "BodyLabels"}

problems = []


def problem(message):
    problems.append(message)


def text_of(element):
    return " ".join((element.text or "").split()) if element is not None else ""


def new_instance(class_name):
    if class_name == "vtkNIFTIImageReader":
        return vtkNIFTIImageReader()
    cls = getattr(spacetreemesh, class_name, None)
    if cls is None:
        problem("class %s is not in the spacetreemesh package" % class_name)
        return None
    return cls()


def as_int(value):
    """C++ bool getters come back as Python bool; compare them as 0/1."""
    return int(value)


def check_int_property(where, prop, obj, printed):
    name = prop.get("name")
    command = prop.get("command") or ""
    defaults = [int(v) for v in (prop.get("default_values") or "").split()]
    if name == "BodyLabels":
        if defaults or prop.get("number_of_elements") != "0":
            problem("%s: BodyLabels must default to empty, XML has %r" % (where, defaults))
        if obj.GetNumberOfBodyLabels() != 0:
            problem("%s: C++ GetNumberOfBodyLabels() is %d, XML default is empty"
                    % (where, obj.GetNumberOfBodyLabels()))
        for attribute, method in (("command", "SetBodyLabel"), ("clean_command", "RemoveAllBodyLabels")):
            if prop.get(attribute) != method:
                problem("%s: BodyLabels %s is %r, expected %r" % (where, attribute, prop.get(attribute), method))
        # The ParaView calling convention: clean, then SetBodyLabel(index, value) per element.
        obj.RemoveAllBodyLabels()
        obj.SetBodyLabel(0, 5)
        obj.SetBodyLabel(1, 9)
        if (obj.GetNumberOfBodyLabels(), obj.GetBodyLabel(0), obj.GetBodyLabel(1)) != (2, 5, 9):
            problem("%s: SetBodyLabel(index, label) does not store the labels" % where)
        if "BodyLabels: 5 9" not in str(obj):
            problem("%s: PrintSelf does not show the body labels 5 9" % where)
        obj.RemoveAllBodyLabels()
        if obj.GetNumberOfBodyLabels() != 0:
            problem("%s: RemoveAllBodyLabels() leaves %d labels" % (where, obj.GetNumberOfBodyLabels()))
        return
    if not command.startswith("Set"):
        problem("%s: unexpected command %r" % (where, command))
        return
    getter_name = "Get" + command[3:]
    setter = getattr(obj, command, None)
    getter = getattr(obj, getter_name, None)
    if setter is None or getter is None:
        problem("%s: %s has no %s/%s" % (where, obj.GetClassName(), command, getter_name))
        return
    count = int(prop.get("number_of_elements") or "1")
    if len(defaults) != count:
        problem("%s: %d default values for %d elements" % (where, len(defaults), count))
        return
    actual = getter()
    actual = [as_int(v) for v in actual] if isinstance(actual, (tuple, list)) else [as_int(actual)]
    if actual != defaults:
        problem("%s: XML default %r, C++ %s() = %r" % (where, defaults, getter_name, actual))
    if name not in printed:
        problem("%s: PrintSelf of %s does not mention %s" % (where, obj.GetClassName(), name))

    # Domains against the C++ clamps.
    for domain in prop:
        if domain.tag == "IntRangeDomain":
            low, high = int(domain.get("min")), int(domain.get("max"))
            if not low <= defaults[0] <= high:
                problem("%s: default %d outside the domain [%d, %d]" % (where, defaults[0], low, high))
            for probe, expected in ((high, high), (high + 1, high), (low, low), (low - 1, low)):
                setter(probe)
                if getter() != expected:
                    problem("%s: %s(%d) gives %s() = %r, the XML range [%d, %d] expects %d"
                            % (where, command, probe, getter_name, getter(), low, high, expected))
            setter(defaults[0])
        elif domain.tag == "BooleanDomain":
            if defaults[0] not in (0, 1):
                problem("%s: boolean default %d" % (where, defaults[0]))
            for value, word in ((1, "On"), (0, "Off")):
                setter(value)
                if as_int(getter()) != value:
                    problem("%s: %s(%d) does not stick" % (where, command, value))
                if "%s: %s" % (name, word) not in str(obj):
                    problem("%s: PrintSelf does not show '%s: %s'" % (where, name, word))
            setter(defaults[0])
        elif domain.tag == "EnumerationDomain":
            entries = [(int(e.get("value")), e.get("text")) for e in domain.findall("Entry")]
            values = [v for v, _ in entries]
            if defaults[0] not in values:
                problem("%s: default %d is no enumeration entry %r" % (where, defaults[0], entries))
            for value, text in entries:
                constant = getattr(type(obj), text.upper(), None)
                if constant is None or int(constant) != value:
                    problem("%s: entry %s=%d has no matching C++ enum constant (%r)"
                            % (where, text, value, constant))
                setter(value)
                if getter() != value:
                    problem("%s: %s(%d) gives %r" % (where, command, value, getter()))
                if "%s: %s" % (name, text) not in str(obj):
                    problem("%s: PrintSelf does not show '%s: %s'" % (where, name, text))
            setter(max(values) + 1)
            if getter() != max(values):
                problem("%s: %s(%d) is not clamped to %d" % (where, command, max(values) + 1, max(values)))
            setter(defaults[0])


def check_label_array(where, prop, obj):
    if prop.get("command") != "SetInputArrayToProcess":
        problem("%s: command %r" % (where, prop.get("command")))
    info = obj.GetInputArrayInformation(0)
    association = info.Get(vtkDataObject.FIELD_ASSOCIATION())
    attribute = info.Get(vtkDataObject.FIELD_ATTRIBUTE_TYPE())
    if association != vtkDataObject.FIELD_ASSOCIATION_POINTS_THEN_CELLS:
        problem("%s: C++ default association %r, expected points then cells" % (where, association))
    if attribute != vtkDataSetAttributes.SCALARS:
        problem("%s: C++ default attribute %r, expected the active scalars" % (where, attribute))
    domain = prop.find("ArrayListDomain")
    if domain is None or domain.get("attribute_type") != "Scalars":
        problem("%s: the array list should prefer the scalars" % where)


xml_files = sorted(glob.glob(os.path.join(XML_DIR, "*.xml")))
T.check(len(xml_files) == 4, "expected 4 XML files in %s, found %r" % (XML_DIR, xml_files))
found = set()
fresh = {}
for path in xml_files:
    root = ET.parse(path).getroot()
    T.check_equal(root.tag, "ServerManagerConfiguration", "root of %s" % path)
    for group in root.findall("ProxyGroup"):
        for proxy in group:
            group_name, proxy_name = group.get("name"), proxy.get("name")
            where = "%s:%s" % (os.path.basename(path), proxy_name)
            found.add((group_name, proxy_name))
            doc = proxy.find("Documentation")
            if not text_of(doc) or not doc.get("short_help") or not doc.get("long_help"):
                problem("%s: the proxy lacks a Documentation with text, short_help and long_help" % where)
            hints = proxy.find("Hints")
            if group_name == "filters":
                menu = hints.find("ShowInMenu") if hints is not None else None
                if menu is None or menu.get("category") != CATEGORY:
                    problem("%s: not in menu category %r" % (where, CATEGORY))
            else:
                factory = hints.find("ReaderFactory") if hints is not None else None
                if factory is None or sorted(factory.get("extensions", "").split()) != ["nii", "nii.gz"]:
                    problem("%s: the ReaderFactory must claim nii and nii.gz" % where)
            obj = new_instance(proxy.get("class"))
            if obj is None:
                continue
            fresh[proxy_name] = proxy
            printed = str(obj)
            for prop in proxy:
                if not prop.tag.endswith("Property"):
                    continue
                name = prop.get("name")
                pwhere = "%s.%s" % (where, name)
                if not text_of(prop.find("Documentation")):
                    problem("%s: no Documentation text" % pwhere)
                command = prop.get("command")
                if command and not hasattr(obj, command):
                    problem("%s: %s has no method %s" % (pwhere, obj.GetClassName(), command))
                if prop.tag == "IntVectorProperty":
                    check_int_property(pwhere, prop, obj, printed)
                elif name == "LabelArray":
                    check_label_array(pwhere, prop, obj)
                elif name not in SPECIAL:
                    problem("%s: property of type %s is not covered by this test" % (pwhere, prop.tag))
if found != EXPECTED_PROXIES:
    problem("proxies in the XML files: %r, expected %r" % (sorted(found), sorted(EXPECTED_PROXIES)))

# --- the same defaults through ParaView's proxies ------------------------------------------------
from paraview import servermanager  # noqa: E402
from paraview.simple import LoadPlugin  # noqa: E402

LoadPlugin(PLUGIN, ns=globals())
for label_function in ("ImageToSpacetree", "SpacetreeBalance", "SpacetreeTessellate"):
    if not callable(globals().get(label_function)):
        problem("paraview.simple has no %s after LoadPlugin" % label_function)
pxm = servermanager.ProxyManager()
for (group_name, proxy_name) in sorted(found):
    sm_proxy = pxm.SMProxyManager.NewProxy(group_name, proxy_name)
    if sm_proxy is None:
        problem("ParaView cannot create %s/%s after LoadPlugin" % (group_name, proxy_name))
        continue
    proxy = servermanager._getPyProxy(sm_proxy)
    proxy.UpdateVTKObjects()
    vtk_object = proxy.GetClientSideObject()
    xml_proxy = fresh.get(proxy_name)
    if xml_proxy is None:
        continue
    if vtk_object.GetClassName() != xml_proxy.get("class"):
        problem("%s: ParaView made a %s" % (proxy_name, vtk_object.GetClassName()))
        continue
    for prop in xml_proxy.findall("IntVectorProperty"):
        name = prop.get("name")
        defaults = [int(v) for v in (prop.get("default_values") or "").split()]
        sm_property = sm_proxy.GetProperty(name)
        value = [sm_property.GetElement(i) for i in range(sm_property.GetNumberOfElements())]
        if value != defaults:
            problem("%s.%s: proxy value %r, XML default %r" % (proxy_name, name, value, defaults))
        if name == "BodyLabels":
            pushed = [vtk_object.GetBodyLabel(i) for i in range(vtk_object.GetNumberOfBodyLabels())]
        else:
            pushed = getattr(vtk_object, "Get" + prop.get("command")[3:])()
            pushed = [as_int(pushed)]
        if pushed != defaults:
            problem("%s.%s: pushed to the VTK object as %r, XML default %r"
                    % (proxy_name, name, pushed, defaults))
    # A value set on the proxy reaches the VTK object.
    if proxy_name == "stmImageToSpacetree":
        proxy.BodyLabels = [4, 2]
        proxy.MaxCellSize = 8
        proxy.UpdateVTKObjects()
        got = ([vtk_object.GetBodyLabel(i) for i in range(vtk_object.GetNumberOfBodyLabels())],
               vtk_object.GetMaxCellSize())
        if got != ([4, 2], 8):
            problem("stmImageToSpacetree: BodyLabels [4, 2], MaxCellSize 8 reached the VTK object as %r"
                    % (got,))
        proxy.BodyLabels = []
        proxy.UpdateVTKObjects()
        if vtk_object.GetNumberOfBodyLabels() != 0:
            problem("stmImageToSpacetree: clearing BodyLabels on the proxy leaves %d labels"
                    % vtk_object.GetNumberOfBodyLabels())

if problems:
    raise AssertionError("%d mismatches between the plugin XML and the C++ classes:\n  %s"
                         % (len(problems), "\n  ".join(problems)))
print("property defaults: %d proxies agree" % len(found))
