// SPDX-License-Identifier: BSD-3-Clause
#include "stmLabelTable.h"

#include "Export/LabelTable.h"

#include "vtkDataArray.h"
#include "vtkFieldData.h"
#include "vtkNew.h"
#include "vtkObjectFactory.h"
#include "vtkStringArray.h"
#include "vtkTypeInt64Array.h"

#include <fstream>

vtkStandardNewMacro(stmLabelTable);

bool stmLabelTable::ReadFile(const char* fileName)
{
  this->Entries.clear();
  this->LastError.clear();
  this->Modified();
  std::ifstream in(fileName ? fileName : "");
  if (!in)
  {
    this->LastError =
      std::string("cannot open the label table '") + (fileName ? fileName : "") + "'";
    return false;
  }
  std::vector<stm::MaterialName> names;
  const stm::Status status = stm::ParseLabelTable(in, names);
  if (!status.IsOk())
  {
    this->LastError = std::string(fileName) + ": " + status.GetMessage();
    return false;
  }
  for (stm::MaterialName& entry : names)
  {
    this->Entries.emplace_back(entry.Label, std::move(entry.Name));
  }
  return true;
}

bool stmLabelTable::ReadFieldData(vtkFieldData* fieldData)
{
  this->Entries.clear();
  this->LastError.clear();
  this->Modified();
  if (!fieldData)
  {
    return true;
  }
  vtkStringArray* names =
    vtkStringArray::SafeDownCast(fieldData->GetAbstractArray(GetNamesArrayName()));
  vtkDataArray* labels = fieldData->GetArray(GetLabelsArrayName());
  if (!fieldData->GetAbstractArray(GetNamesArrayName()) && !labels)
  {
    return true;
  }
  if (!names || !labels || labels->GetNumberOfComponents() != 1 ||
    labels->GetDataType() == VTK_FLOAT || labels->GetDataType() == VTK_DOUBLE ||
    names->GetNumberOfValues() != labels->GetNumberOfTuples())
  {
    this->LastError = std::string("the label table of the field data is malformed: it needs a "
                                  "string array \"") +
      GetNamesArrayName() + "\" and an integer array \"" + GetLabelsArrayName() +
      "\" of the same length";
    return false;
  }
  for (vtkIdType i = 0; i < names->GetNumberOfValues(); ++i)
  {
    this->Entries.emplace_back(
      static_cast<vtkTypeInt64>(labels->GetComponent(i, 0)), names->GetValue(i));
  }
  return true;
}

void stmLabelTable::WriteFieldData(vtkFieldData* fieldData) const
{
  if (!fieldData)
  {
    return;
  }
  vtkNew<vtkStringArray> names;
  names->SetName(GetNamesArrayName());
  vtkNew<vtkTypeInt64Array> labels;
  labels->SetName(GetLabelsArrayName());
  for (const auto& entry : this->Entries)
  {
    labels->InsertNextValue(entry.first);
    names->InsertNextValue(entry.second);
  }
  fieldData->RemoveArray(GetNamesArrayName());
  fieldData->RemoveArray(GetLabelsArrayName());
  fieldData->AddArray(names);
  fieldData->AddArray(labels);
}

vtkTypeInt64 stmLabelTable::GetLabel(int index) const
{
  return index >= 0 && index < this->GetNumberOfLabels() ? this->Entries[index].first : 0;
}

const char* stmLabelTable::GetName(int index) const
{
  return index >= 0 && index < this->GetNumberOfLabels() ? this->Entries[index].second.c_str()
                                                         : nullptr;
}

void stmLabelTable::SetName(vtkTypeInt64 label, const char* name)
{
  for (auto& entry : this->Entries)
  {
    if (entry.first == label)
    {
      entry.second = name ? name : "";
      this->Modified();
      return;
    }
  }
  this->Entries.emplace_back(label, name ? name : "");
  this->Modified();
}

void stmLabelTable::RemoveAllLabels()
{
  this->Entries.clear();
  this->Modified();
}

void stmLabelTable::PrintSelf(ostream& os, vtkIndent indent)
{
  this->Superclass::PrintSelf(os, indent);
  os << indent << "NumberOfLabels: " << this->Entries.size() << "\n";
  for (const auto& entry : this->Entries)
  {
    os << indent.GetNextIndent() << entry.first << ": " << entry.second << "\n";
  }
}
