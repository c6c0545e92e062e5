# SPDX-License-Identifier: BSD-3-Clause
"""Nearest-neighbour upsampling of a label image, for the benchmarks of large images (issue 8).

    pvpython scripts/upsample-atlas.py /usr/share/mricron/templates/aal.nii.gz 2 aal_x2.nii
    pvpython scripts/upsample-atlas.py /usr/share/mricron/templates/aal.nii.gz 2.5 aal_x2.5.nii

Each output voxel takes the label of the input voxel its centre lies in (vtkImageResize with
magnification factors, voxels as cells, no interpolation); the spacing shrinks by the factor and
the physical extent stays. AAL (181 x 217 x 181) becomes 362 x 434 x 362 (57 million voxels) at
2 and 452 x 542 x 452 (111 million) at 2.5. The output is uncompressed NIfTI-1 with the input's
qform and sform.
"""

import gzip
import os
import shutil
import sys
import tempfile

from vtkmodules.vtkImagingCore import vtkImageResize
from vtkmodules.vtkIOImage import vtkNIFTIImageReader, vtkNIFTIImageWriter


def main(argv):
    if len(argv) != 4:
        sys.stderr.write(__doc__)
        return 2
    source, factor, output = argv[1], float(argv[2]), argv[3]
    if not factor > 0:
        sys.stderr.write("upsample-atlas: the factor must be positive\n")
        return 2
    with tempfile.TemporaryDirectory() as folder:
        plain = source
        if source.endswith(".gz"):
            # Read through a plain copy, as stmesh's own reader does.
            plain = os.path.join(folder, "input.nii")
            with gzip.open(source) as compressed, open(plain, "wb") as copy:
                shutil.copyfileobj(compressed, copy)
        reader = vtkNIFTIImageReader()
        reader.SetFileName(plain)
        reader.Update()
        if reader.GetErrorCode() != 0 or reader.GetOutput().GetNumberOfPoints() == 0:
            sys.stderr.write("upsample-atlas: cannot read %s\n" % source)
            return 1
        resize = vtkImageResize()
        resize.SetInputConnection(reader.GetOutputPort())
        resize.SetResizeMethodToMagnificationFactors()
        resize.SetMagnificationFactors(factor, factor, factor)
        resize.BorderOn()
        resize.InterpolateOff()
        writer = vtkNIFTIImageWriter()
        writer.SetInputConnection(resize.GetOutputPort())
        writer.SetFileName(output)
        if reader.GetQFormMatrix():
            writer.SetQFormMatrix(reader.GetQFormMatrix())
        if reader.GetSFormMatrix():
            writer.SetSFormMatrix(reader.GetSFormMatrix())
        writer.Write()
        if writer.GetErrorCode() != 0:
            sys.stderr.write("upsample-atlas: cannot write %s\n" % output)
            return 1
        image = resize.GetOutput()
        print("%s: %s voxels of %s" % (output, " x ".join(map(str, image.GetDimensions())),
                                        " x ".join("%g" % s for s in image.GetSpacing())))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
