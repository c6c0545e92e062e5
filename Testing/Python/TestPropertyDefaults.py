"""The plugin's server-manager XML agrees with the C++ classes (run by pvpython).

For every proxy of /work/main/Plugin/*.xml (STM_XML_DIR):
- the proxy and every property carry a non-empty <Documentation>;
- every filter is in the menu category "Spacetree Mesh"; the reader claims .nii and .nii.gz;
  each writer claims its extension (.msh, .mesh, .inp, .feb, .exo);
- every IntVectorProperty with command="SetX" has an XML default equal to GetX() of a fresh
  instance of the wrapped class (BodyLabels: empty XML default and GetNumberOfBodyLabels() == 0),
  its range domain equals the C++ clamp range, its enumeration the C++ enum;
- every DoubleVectorProperty and StringVectorProperty with command="SetX" likewise; the
  repeated (label, value) pair properties default to empty and store what their command sets;
  the implicit-function (region) properties default to no function;
- PrintSelf (str(obj)) of each class mentions every property, an enumeration by its entry's
  text without blanks ("TemplateRule: RegularFaces"); a fresh stmSpacetreeTessellate prints
  its defaults and its result NumberOfInsertedPoints (PRINTED_DEFAULTS);
- the proxies made by ParaView from these XML files hold the same defaults and push them
  unchanged into their VTK objects.
All mismatches are collected and reported together.
"""
import glob
import os
import xml.etree.ElementTree as ET

import spacetreemesh
from vtkmodules.vtkCommonDataModel import vtkDataObject, vtkDataSetAttributes

import stmtesting as T

XML_DIR = T.env("STM_XML_DIR")
PLUGIN = T.env("STM_PLUGIN")
CATEGORY = "Spacetree Mesh"
EXPECTED_PROXIES = {
    ("filters", "stmImageToSpacetree"),
    ("filters", "stmSpacetreeBalance"),
    ("filters", "stmSpacetreeTessellate"),
    ("filters", "stmMarchingSimplices"),
    ("filters", "stmMultiMaterialCut"),
    ("filters", "stmSeparatingFunction"),
    ("filters", "stmVertexSnap"),
    ("filters", "stmBoundarySmooth"),
    ("filters", "stmInterfaceSurface"),
    ("sources", "stmNIFTIReader"),
    ("writers", "stmGmshWriter"),
    ("writers", "stmMeditWriter"),
    ("writers", "stmAbaqusWriter"),
    ("writers", "stmFEBioWriter"),
    ("writers", "stmExodusWriter"),
}
# The file extension each writer claims.
WRITER_EXTENSIONS = {"stmGmshWriter": "msh", "stmMeditWriter": "mesh", "stmAbaqusWriter": "inp",
                     "stmFEBioWriter": "feb", "stmExodusWriter": "exo"}
# Properties whose command is not a plain SetX/GetX pair, and what they are checked by instead.
SPECIAL = {"LabelArray", "Input", "FileName", "BodyLabels", "SizingArray", "FunctionArray",
           "GrayImage"}
# Repeated (label, value) pairs: property name -> (count getter, PrintSelf text after setting 5, 3).
PAIR_PROPERTIES = {
    "LabelMaxCellSizes": ("GetNumberOfLabelMaxCellSizes", "LabelMaxCellSizes: 5:3"),
    "LabelBalanceLevels": ("GetNumberOfLabelBalanceLevels", "LabelBalanceLevels: 5:3"),
}
# Implicit-function properties: property name -> getter.
REGION_PROPERTIES = {"RefinementRegion": "GetRefinementRegion", "BalanceRegion": "GetBalanceRegion",
                     "ImplicitFunction": "GetImplicitFunction"}

# The widgets of each implicit-function property (sorted), when not the regions' four.
REGION_WIDGETS = {"ImplicitFunction": ["Box", "Cylinder", "Plane", "Quadric", "Sphere"]}

# Lines the PrintSelf of a fresh instance must contain, beyond the generic checks: the defaults
# in words and result values that are no property.
PRINTED_DEFAULTS = {
    "stmSpacetreeTessellate": ["OutputType: Simplicial", "TemplateRule: RegularFaces",
                               "CellTemplate: Checkerboard", "IncludeBackground: Off",
                               "BoundaryLayers: 0", "NumberOfInsertedPoints: 0",
                               "SeparatingFunction: Labels", "SmoothingSigma: 1",
                               "NumberOfBoundaryLayers: 0"],
    "stmMarchingSimplices": ["IsoValue: 0", "ZeroTolerance: 1e-09", "OutputMode: Volume",
                             "KeepSide: Both", "InsideMaterial: 1", "OutsideMaterial: 0",
                             "NumberOfSplitCells: 0", "NumberOfCutPoints: 0"],
    "stmSeparatingFunction": ["Mode: ImplicitFunction", "Threshold: 0",
                              "InsideAboveThreshold: On"],
    "stmVertexSnap": ["Alpha: 0.333333", "QualityBound: 0", "SnapRule: QualityDriven",
                      "IsoValue: 0", "ZeroTolerance: 1e-09", "Projection: Edge",
                      "ImplicitFunction: (none)", "Threshold: 0", "InsideAboveThreshold: On",
                      "NumberOfSnappedPoints: 0", "NumberOfRefusedSnaps: 0",
                      "NumberOfAdjustedPoints: 0"],
    "stmBoundarySmooth": ["NumberOfIterations: 20", "Method: Taubin", "RelaxationFactor: 0.5",
                          "PassBand: 0.1", "MaxDisplacement: 0", "NumberOfInteriorLayers: 2",
                          "InteriorRelaxationInterval: 4", "SmallPartPoints: 8",
                          "MaxConditionNumber: 3.5", "MinDihedralAngle: 15",
                          "NumberOfImprovementSweeps: 10", "ImprovementMovesInterfaces: On",
                          "SplitInteriorEdges: On",
                          "RestoreOriginalVolumes: Off",
                          "BackgroundMaterial: 0", "ProjectToFunction: Off",
                          "ImplicitFunction: (none)", "NumberOfMovedPoints: 0",
                          "NumberOfRejectedMoves: 0", "NumberOfImprovedPoints: 0",
                          "NumberOfSplitEdges: 0", "NumberOfKeptPoints: 0",
                          "LargestVolumeErrorBefore: 0", "LargestVolumeErrorAfter: 0"],
    "stmInterfaceSurface": ["IncludeOuterBoundary: On", "BackgroundMaterial: 0",
                            "OuterLabel: -1"],
    "stmMultiMaterialCut": ["BackgroundMaterial: 0", "ZeroTolerance: 1e-09",
                            "VertexSnapping: On", "NumberOfMaterials: 0",
                            "NumberOfSplitCells: 0", "NumberOfSplitAssignedCells: 0",
                            "NumberOfCutPoints: 0", "NumberOfSnappedPoints: 0"],
}

problems = []


def problem(message):
    problems.append(message)


def text_of(element):
    return " ".join((element.text or "").split()) if element is not None else ""


def new_instance(class_name):
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
                # "Regular Faces" is REGULAR_FACES in C++ and "RegularFaces" in PrintSelf.
                constant = getattr(type(obj), text.upper().replace(" ", "_"), None)
                if constant is None or int(constant) != value:
                    problem("%s: entry %s=%d has no matching C++ enum constant (%r)"
                            % (where, text, value, constant))
                setter(value)
                if getter() != value:
                    problem("%s: %s(%d) gives %r" % (where, command, value, getter()))
                shown = text.replace(" ", "")
                if "%s: %s\n" % (name, shown) not in str(obj):
                    problem("%s: PrintSelf does not show '%s: %s'" % (where, name, shown))
            setter(max(values) + 1)
            if getter() != max(values):
                problem("%s: %s(%d) is not clamped to %d" % (where, command, max(values) + 1, max(values)))
            setter(defaults[0])


def check_pair_property(where, prop, obj):
    name = prop.get("name")
    count_getter, printed_pair = PAIR_PROPERTIES[name]
    if prop.get("default_values") or prop.get("number_of_elements") != "0":
        problem("%s: must default to empty" % where)
    if prop.get("number_of_elements_per_command") != "2" or prop.get("repeat_command") != "1":
        problem("%s: must be repeated (label, value) pairs" % where)
    if getattr(obj, count_getter)() != 0:
        problem("%s: C++ %s() is not 0 by default" % (where, count_getter))
    getattr(obj, prop.get("command"))(5, 3)
    if getattr(obj, count_getter)() != 1 or printed_pair not in str(obj):
        problem("%s: %s(5, 3) is not stored or not printed as %r" % (where, prop.get("command"), printed_pair))
    getattr(obj, prop.get("clean_command"))()
    if getattr(obj, count_getter)() != 0:
        problem("%s: %s() leaves entries" % (where, prop.get("clean_command")))


def check_region_property(where, prop, obj):
    name = prop.get("name")
    if getattr(obj, REGION_PROPERTIES[name])() is not None:
        problem("%s: C++ default is not 'no region'" % where)
    if "%s: (none)" % name not in str(obj):
        problem("%s: PrintSelf does not show '%s: (none)'" % (where, name))
    domain = prop.find("ProxyListDomain")
    names = sorted(p.get("name") for p in domain.findall("Proxy")) if domain is not None else []
    expected = REGION_WIDGETS.get(name, ["Box", "Cylinder", "Plane", "Sphere"])
    if names != expected:
        problem("%s: the region widgets are %r" % (where, names))


def check_value_property(where, prop, obj, printed, parse):
    """A DoubleVectorProperty or StringVectorProperty with a SetX/GetX pair."""
    name = prop.get("name")
    command = prop.get("command") or ""
    getter = getattr(obj, "Get" + command[3:], None)
    if not command.startswith("Set") or getter is None:
        problem("%s: no Set/Get pair for command %r" % (where, command))
        return
    defaults = [parse(v) for v in (prop.get("default_values") or "").split()]
    actual = getter()
    actual = list(actual) if isinstance(actual, (tuple, list)) else [actual]
    if actual != defaults:
        problem("%s: XML default %r, C++ %r" % (where, defaults, actual))
    if name not in printed:
        problem("%s: PrintSelf of %s does not mention %s" % (where, obj.GetClassName(), name))


def check_sizing_array(where, prop, obj):
    if prop.get("command") != "SetInputArrayToProcess" or prop.get("default_values") != "1":
        problem("%s: must set input array 1" % where)
    if obj.GetUseSizingArray():
        problem("%s: the sizing array must be off by default" % where)


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
# One proxy per XML file.
T.check(len(xml_files) == len(EXPECTED_PROXIES), "expected %d XML files in %s, found %r"
        % (len(EXPECTED_PROXIES), XML_DIR, xml_files))
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
            elif group_name == "writers":
                factory = hints.find("WriterFactory") if hints is not None else None
                if factory is None or factory.get("extensions") != WRITER_EXTENSIONS.get(proxy_name):
                    problem("%s: the WriterFactory must claim %s" % (where,
                                                                     WRITER_EXTENSIONS.get(proxy_name)))
            else:
                factory = hints.find("ReaderFactory") if hints is not None else None
                if factory is None or sorted(factory.get("extensions", "").split()) != ["nii", "nii.gz"]:
                    problem("%s: the ReaderFactory must claim nii and nii.gz" % where)
            obj = new_instance(proxy.get("class"))
            if obj is None:
                continue
            fresh[proxy_name] = proxy
            printed = str(obj)
            for line in PRINTED_DEFAULTS.get(proxy.get("class"), []):
                if "%s%s\n" % (" " * 2, line) not in printed:
                    problem("%s: PrintSelf of a fresh instance does not show %r" % (where, line))
            if proxy.get("class") == "stmSpacetreeTessellate" and obj.GetNumberOfInsertedPoints() != 0:
                problem("%s: GetNumberOfInsertedPoints() of a fresh instance is %d"
                        % (where, obj.GetNumberOfInsertedPoints()))
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
                if name in PAIR_PROPERTIES:
                    check_pair_property(pwhere, prop, obj)
                elif name in REGION_PROPERTIES:
                    check_region_property(pwhere, prop, obj)
                elif name == "SizingArray":
                    check_sizing_array(pwhere, prop, obj)
                elif prop.tag == "IntVectorProperty":
                    check_int_property(pwhere, prop, obj, printed)
                elif prop.tag == "DoubleVectorProperty":
                    check_value_property(pwhere, prop, obj, printed, float)
                elif prop.tag == "StringVectorProperty" and name not in SPECIAL:
                    check_value_property(pwhere, prop, obj, printed, str)
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
    for prop in xml_proxy.findall("IntVectorProperty") + xml_proxy.findall("DoubleVectorProperty"):
        name = prop.get("name")
        parse = int if prop.tag == "IntVectorProperty" else float
        defaults = [parse(v) for v in (prop.get("default_values") or "").split()]
        sm_property = sm_proxy.GetProperty(name)
        value = [sm_property.GetElement(i) for i in range(sm_property.GetNumberOfElements())]
        if value != defaults:
            problem("%s.%s: proxy value %r, XML default %r" % (proxy_name, name, value, defaults))
        if name == "BodyLabels":
            pushed = [vtk_object.GetBodyLabel(i) for i in range(vtk_object.GetNumberOfBodyLabels())]
        elif name in PAIR_PROPERTIES:
            pushed = [] if getattr(vtk_object, PAIR_PROPERTIES[name][0])() == 0 else ["entries"]
        else:
            pushed = getattr(vtk_object, "Get" + prop.get("command")[3:])()
            pushed = [parse(v) for v in pushed] if isinstance(pushed, (tuple, list)) else [parse(pushed)]
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
        proxy.RefinementPattern = "2x2x1,2x2x2"
        proxy.LabelMaxCellSizes = [7, 2.5]
        proxy.RegionMaxCellSize = 0.5
        proxy.UpdateVTKObjects()
        got = (vtk_object.GetRefinementPattern(), vtk_object.GetNumberOfLabelMaxCellSizes(),
               vtk_object.GetRegionMaxCellSize(),
               vtk_object.GetRefinementRegion().GetClassName() if vtk_object.GetRefinementRegion() else None)
        if got != ("2x2x1,2x2x2", 1, 0.5, "vtkPVBox"):
            problem("stmImageToSpacetree: pattern, label size, region size and the default Box region "
                    "reached the VTK object as %r" % (got,))
        proxy.BodyLabels = []
        proxy.UpdateVTKObjects()
        if vtk_object.GetNumberOfBodyLabels() != 0:
            problem("stmImageToSpacetree: clearing BodyLabels on the proxy leaves %d labels"
                    % vtk_object.GetNumberOfBodyLabels())

if problems:
    raise AssertionError("%d mismatches between the plugin XML and the C++ classes:\n  %s"
                         % (len(problems), "\n  ".join(problems)))
print("property defaults: %d proxies agree" % len(found))
