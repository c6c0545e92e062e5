// SPDX-License-Identifier: BSD-3-Clause
/**
 * @class   stmLabelTable
 * @brief   the names of an image's labels: read from an atlas's label file, carried on a mesh
 *          as field data, used by the finite-element writers to name the material groups
 *
 * ReadFile reads a label table: one label per line, its integer value first, then its name
 * (the first double-quoted text on the line, as in ITK-SNAP's label descriptions, or else the
 * second word, as in MRIcron's .txt files beside the atlases, e.g.
 * /usr/share/mricron/templates/aal.nii.txt, and FreeSurfer's colour tables); '#' starts a
 * comment line. A malformed line or a label named twice is an error (GetLastError).
 *
 * On a dataset the table is two field arrays of the same length: the strings "MaterialNames"
 * and the 64-bit integers "MaterialNameLabels". stmesh --label-names puts them on its mesh;
 * stmGmshWriter, stmMeditWriter, stmAbaqusWriter and stmFEBioWriter name each material's group
 * from them. In Python:
 * @code
 * table = stmLabelTable()
 * table.ReadFile("/usr/share/mricron/templates/aal.nii.txt")
 * table.WriteFieldData(mesh.GetFieldData())
 * @endcode
 *
 * @sa stmGmshWriter
 */

#ifndef stmLabelTable_h
#define stmLabelTable_h

#include "SpacetreeMeshFiltersModule.h" // for export macro
#include "vtkObject.h"

#include <string>
#include <utility>
#include <vector>

class vtkFieldData;

class SPACETREEMESHFILTERS_EXPORT stmLabelTable : public vtkObject
{
public:
  static stmLabelTable* New();
  vtkTypeMacro(stmLabelTable, vtkObject);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /// Replaces the table with the file's; false (table empty) on an error.
  bool ReadFile(const char* fileName);

  /// Replaces the table with the one in the field data (none there: empty); false (table
  /// empty) if the arrays are malformed.
  bool ReadFieldData(vtkFieldData* fieldData);

  /// Puts the table into the field data, replacing a table there.
  void WriteFieldData(vtkFieldData* fieldData) const;

  /// The number of labels, and each one's value and name, in the order read.
  int GetNumberOfLabels() const { return static_cast<int>(this->Entries.size()); }
  vtkTypeInt64 GetLabel(int index) const;
  const char* GetName(int index) const;

  /// Adds a label (a label already there gets the new name); removes all.
  void SetName(vtkTypeInt64 label, const char* name);
  void RemoveAllLabels();

  /// Why the last ReadFile or ReadFieldData failed ("" after a success).
  const char* GetLastError() const { return this->LastError.c_str(); }

  /// The field arrays' names.
  static const char* GetNamesArrayName() { return "MaterialNames"; }
  static const char* GetLabelsArrayName() { return "MaterialNameLabels"; }

protected:
  stmLabelTable() = default;
  ~stmLabelTable() override = default;

private:
  stmLabelTable(const stmLabelTable&) = delete;
  void operator=(const stmLabelTable&) = delete;

  std::vector<std::pair<vtkTypeInt64, std::string>> Entries;
  std::string LastError;
};

#endif
