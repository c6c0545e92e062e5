// SPDX-License-Identifier: BSD-3-Clause
/**
 * @brief   the core's Dim coordinates of a mesh's points (private to the module)
 *
 * The core moves points in Dim coordinates. A tetrahedral mesh's are its 3D coordinates; a
 * triangle mesh must be planar, and its core coordinates are two coordinates in its plane: the
 * two other axes when the plane is orthogonal to an axis, so that moved points keep exact
 * coordinates, else an orthonormal frame. stmVertexSnap and stmBoundarySmooth both move points
 * this way.
 */

#ifndef stmPlaneFrame_h
#define stmPlaneFrame_h

#include "vtkCellArray.h"
#include "vtkIdList.h"
#include "vtkMath.h"
#include "vtkNew.h"
#include "vtkPoints.h"
#include "vtkSMPTools.h"
#include "vtkUnstructuredGrid.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

class stmPlaneFrame
{
public:
  /// For a triangle mesh (dimension 2), finds its plane; false with `error` set (ending with
  /// `remedy`) when the triangles have no area or are not in one plane. Always true in 3D.
  bool Build(vtkUnstructuredGrid* mesh, int dimension, const char* remedy, std::string& error)
  {
    this->Flat = dimension == 2;
    if (!this->Flat)
    {
      return true;
    }
    vtkPoints* points = mesh->GetPoints();
    vtkCellArray* cells = mesh->GetCells();
    vtkNew<vtkIdList> ids;
    double normal[3] = { 0, 0, 0 };
    for (vtkIdType cell = 0; cell < mesh->GetNumberOfCells(); ++cell)
    {
      cells->GetCellAtId(cell, ids);
      double a[3], b[3], c[3], ab[3], ac[3], n[3];
      points->GetPoint(ids->GetId(0), a);
      points->GetPoint(ids->GetId(1), b);
      points->GetPoint(ids->GetId(2), c);
      vtkMath::Subtract(b, a, ab);
      vtkMath::Subtract(c, a, ac);
      vtkMath::Cross(ab, ac, n);
      // Inconsistently oriented triangles must not cancel: align each with the sum so far.
      const double sign = vtkMath::Dot(n, normal) < 0 ? -1.0 : 1.0;
      for (int k = 0; k < 3; ++k)
      {
        normal[k] += sign * n[k];
      }
    }
    if (vtkMath::Norm(normal) == 0.0)
    {
      error = "the triangles have no area";
      return false;
    }
    points->GetPoint(0, this->Origin);
    int zeros = 0, normalAxis = 0;
    for (int k = 0; k < 3; ++k)
    {
      zeros += normal[k] == 0.0 ? 1 : 0;
      normalAxis = normal[k] != 0.0 ? k : normalAxis;
    }
    this->AxisAligned = zeros == 2;
    vtkMath::Normalize(normal);
    if (this->AxisAligned)
    {
      this->Axes[0] = (normalAxis + 1) % 3;
      this->Axes[1] = (normalAxis + 2) % 3;
    }
    else
    {
      vtkMath::Perpendiculars(normal, this->U, this->W, 0.0);
    }
    double bounds[6];
    points->GetBounds(bounds);
    const double tolerance = 1e-9 *
      std::max(1.0,
        std::sqrt((bounds[1] - bounds[0]) * (bounds[1] - bounds[0]) +
          (bounds[3] - bounds[2]) * (bounds[3] - bounds[2]) +
          (bounds[5] - bounds[4]) * (bounds[5] - bounds[4])));
    for (vtkIdType p = 0; p < points->GetNumberOfPoints(); ++p)
    {
      double x[3], d[3];
      points->GetPoint(p, x);
      vtkMath::Subtract(x, this->Origin, d);
      if (std::abs(vtkMath::Dot(d, normal)) > tolerance)
      {
        error = "the triangles do not lie in one plane (point " + std::to_string(p) +
          " is off it); " + remedy;
        return false;
      }
    }
    return true;
  }

  /// The core coordinates of every point, Dim per point (in parallel).
  template <int Dim>
  std::vector<double> CoreCoordinates(vtkPoints* points) const
  {
    std::vector<double> core(static_cast<std::size_t>(points->GetNumberOfPoints()) * Dim);
    vtkSMPTools::For(0, points->GetNumberOfPoints(),
      [&](vtkIdType begin, vtkIdType end)
      {
        for (vtkIdType p = begin; p < end; ++p)
        {
          double x[3];
          points->GetPoint(p, x);
          this->ToCore<Dim>(x, core.data() + p * Dim);
        }
      });
    return core;
  }

  /// Whether core coordinates are copies of point coordinates (3D, or a coordinate plane), so
  /// that a position the core checked is stored exactly.
  bool CopiesCoordinates() const { return !this->Flat || this->AxisAligned; }

  template <int Dim>
  void ToCore(const double x[3], double* core) const
  {
    if (Dim == 3)
    {
      std::copy(x, x + 3, core);
    }
    else if (this->AxisAligned)
    {
      core[0] = x[this->Axes[0]];
      core[1] = x[this->Axes[1]];
    }
    else
    {
      double d[3];
      vtkMath::Subtract(x, this->Origin, d);
      core[0] = vtkMath::Dot(d, this->U);
      core[1] = vtkMath::Dot(d, this->W);
    }
  }

  /// The 3D position of a point at `original` moved to core coordinates: only its in-plane
  /// coordinates change.
  template <int Dim>
  void Lift(const double* core, const double original[3], double x[3]) const
  {
    std::copy(original, original + 3, x);
    if (Dim == 3)
    {
      std::copy(core, core + 3, x);
      return;
    }
    if (this->AxisAligned)
    {
      x[this->Axes[0]] = core[0];
      x[this->Axes[1]] = core[1];
      return;
    }
    double now[2];
    this->ToCore<Dim>(original, now);
    for (int k = 0; k < 3; ++k)
    {
      x[k] += (core[0] - now[0]) * this->U[k] + (core[1] - now[1]) * this->W[k];
    }
  }

  /// A 3D gradient as a gradient in the core coordinates (its in-plane part).
  template <int Dim>
  void FlattenGradient(const double gradient[3], double* core) const
  {
    if (Dim == 3)
    {
      std::copy(gradient, gradient + 3, core);
    }
    else if (this->AxisAligned)
    {
      core[0] = gradient[this->Axes[0]];
      core[1] = gradient[this->Axes[1]];
    }
    else
    {
      core[0] = vtkMath::Dot(gradient, this->U);
      core[1] = vtkMath::Dot(gradient, this->W);
    }
  }

private:
  bool Flat = false;
  int Axes[2] = { 0, 1 };
  bool AxisAligned = true;
  double Origin[3] = { 0, 0, 0 };
  double U[3] = { 1, 0, 0 };
  double W[3] = { 0, 1, 0 };
};

#endif
