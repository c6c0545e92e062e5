"""Writes the seed corpus of FuzzImageReading (corpus/reading/): small valid images of every
format stmesh reads, and corrupt variants of each (bad or huge sizes, wrong types, truncated
data, broken compression, missing data files).

Each file is one byte, the index of the extension in FuzzImageReading.cxx's Extensions
(0 .nii, 1 .nii.gz, 2 .mha, 3 .mhd, 4 .nrrd, 5 .nhdr, 6 .vti), then the file itself. A
detached header may name data.raw (64 bytes beside the input). Run: python3 MakeReaderSeedCorpus.py
"""
import gzip
import os
import struct
import zlib

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", "reading")
NII, NII_GZ, MHA, MHD, NRRD, NHDR, VTI = range(7)
LABELS = bytes([0, 1, 1, 2, 0, 1, 2, 2, 0, 0, 1, 1, 2, 2, 1, 0, 0, 1, 2, 1, 0, 0, 0, 1])  # 4x3x2


def nifti(dims=(4, 3, 2), datatype=2, bitpix=8, pixdim=(1.0, 1.0, 1.0), vox_offset=352.0,
          magic=b"n+1\0", data=LABELS, sizeof_hdr=348, ndim=None, qform=0, sform=0,
          slope=0.0, srow=((1, 0, 0, 0), (0, 1, 0, 0), (0, 0, 1, 0)), quatern=(0.0, 0.0, 0.0)):
    """A NIfTI-1 single file (header, 4 extension bytes, voxels), little endian."""
    dim = [len(dims) if ndim is None else ndim] + list(dims) + [1] * (7 - len(dims))
    header = struct.pack("<i", sizeof_hdr)
    header += b"\0" * 10 + b"\0" * 18 + struct.pack("<i", 0) + struct.pack("<h", 0) + b"r" + b"\0"
    header += struct.pack("<8h", *dim)
    header += struct.pack("<3f", 0.0, 0.0, 0.0)  # intent_p1..3
    header += struct.pack("<hhhh", 0, datatype, bitpix, 0)  # intent_code, datatype, bitpix, slice_start
    header += struct.pack("<8f", 1.0, *pixdim, *([1.0] * (7 - len(pixdim))))
    header += struct.pack("<f", vox_offset)
    header += struct.pack("<ff", slope, 0.0)  # scl_slope, scl_inter
    header += struct.pack("<hbb", 0, 10, 0)  # slice_end, slice_code, xyzt_units
    header += struct.pack("<ffff", 0.0, 0.0, 0.0, 0.0)  # cal_max, cal_min, slice_duration, toffset
    header += struct.pack("<ii", 0, 0)  # glmax, glmin
    header += b"\0" * 80 + b"\0" * 24
    header += struct.pack("<hh", qform, sform)
    header += struct.pack("<6f", *quatern, 0.0, 0.0, 0.0)
    for row in srow:
        header += struct.pack("<4f", *row)
    header += b"\0" * 16 + magic
    assert len(header) == 348, len(header)
    return header + b"\0\0\0\0" + data


def metaimage(dims="4 3 2", element="MET_UCHAR", data=LABELS, extra="", data_file="LOCAL",
              ndims=3):
    text = "ObjectType = Image\nNDims = %s\n%sDimSize = %s\nElementType = %s\n" % (
        ndims, extra, dims, element)
    text += "ElementDataFile = %s\n" % data_file
    return text.encode() + (data if data_file == "LOCAL" else b"")


def nrrd(sizes="12 2 1", type_="uint8", encoding="raw", data=LABELS, extra="", dimension=3,
         data_file=None):
    text = "NRRD0004\ntype: %s\ndimension: %s\nsizes: %s\nencoding: %s\n%s" % (
        type_, dimension, sizes, encoding, extra)
    if data_file:
        return (text + "data file: %s\n" % data_file).encode()
    return (text + "\n").encode() + data


def vti(extent="0 3 0 2 0 1", values=" ".join(str(v) for v in LABELS), type_="UInt8",
        fmt="ascii", spacing="1 1 1", truncate=None, components=1):
    text = ('<?xml version="1.0"?>\n<VTKFile type="ImageData" version="0.1" '
            'byte_order="LittleEndian">\n<ImageData WholeExtent="%s" Origin="0 0 0" '
            'Spacing="%s">\n<Piece Extent="%s">\n<PointData Scalars="labels">\n'
            '<DataArray type="%s" Name="labels" NumberOfComponents="%d" format="%s">%s'
            '</DataArray>\n</PointData>\n<CellData>\n</CellData>\n</Piece>\n</ImageData>\n'
            '</VTKFile>\n') % (extent, spacing, extent, type_, components, fmt, values)
    data = text.encode()
    return data[:truncate] if truncate else data


def main():
    os.makedirs(HERE, exist_ok=True)
    for name in os.listdir(HERE):
        os.remove(os.path.join(HERE, name))

    def write(name, extension, data):
        with open(os.path.join(HERE, name), "wb") as out:
            out.write(bytes([extension]) + data)

    # NIfTI-1, uncompressed.
    write("nii_valid", NII, nifti())
    write("nii_int16", NII, nifti(datatype=4, bitpix=16, data=b"".join(
        struct.pack("<h", v - 1) for v in LABELS)))
    write("nii_float", NII, nifti(datatype=16, bitpix=32, data=b"".join(
        struct.pack("<f", v) for v in LABELS)))
    write("nii_truncated_data", NII, nifti()[:-10])
    write("nii_header_only", NII, nifti()[:348])
    write("nii_half_header", NII, nifti()[:200])
    write("nii_huge_dims", NII, nifti(dims=(32767, 32767, 32767)))
    write("nii_large_dims", NII, nifti(dims=(2000, 2000, 500), datatype=64, bitpix=64))
    write("nii_negative_dim", NII, nifti(dims=(4, -3, 2)))
    write("nii_zero_dim", NII, nifti(dims=(4, 0, 2)))
    write("nii_ndim_zero", NII, nifti(ndim=0))
    write("nii_ndim_nine", NII, nifti(ndim=9))
    write("nii_bad_datatype", NII, nifti(datatype=3, bitpix=8))
    write("nii_rgb", NII, nifti(datatype=128, bitpix=24, data=LABELS * 3))
    write("nii_bitpix_mismatch", NII, nifti(datatype=2, bitpix=64))
    write("nii_vox_offset_beyond", NII, nifti(vox_offset=1e9))
    write("nii_vox_offset_negative", NII, nifti(vox_offset=-400.0))
    write("nii_vox_offset_nan", NII, nifti(vox_offset=float("nan")))
    write("nii_pixdim_nan", NII, nifti(pixdim=(float("nan"), 1.0, float("inf"))))
    write("nii_pixdim_zero", NII, nifti(pixdim=(0.0, -1.0, 0.0)))
    write("nii_bad_magic", NII, nifti(magic=b"xyz\0"))
    write("nii_swapped_size", NII, nifti(sizeof_hdr=0x5C010000))
    write("nii_slope", NII, nifti(slope=2.0))
    write("nii_sform_singular", NII, nifti(sform=1, srow=((0, 0, 0, 0),) * 3))
    write("nii_qform_bad", NII, nifti(qform=1, quatern=(2.0, 2.0, 2.0)))
    write("nii_analyze_pair", NII, nifti(magic=b"ni1\0"))
    # NIfTI-1, gzip.
    write("niigz_valid", NII_GZ, gzip.compress(nifti(), mtime=0))
    write("niigz_truncated", NII_GZ, gzip.compress(nifti(), mtime=0)[:60])
    write("niigz_not_gzip", NII_GZ, nifti())
    write("niigz_huge_dims", NII_GZ, gzip.compress(nifti(dims=(3000, 3000, 3000)), mtime=0))
    write("niigz_bad_crc", NII_GZ, gzip.compress(nifti(), mtime=0)[:-8] + b"\0" * 8)
    # MetaImage with its voxels (.mha).
    write("mha_valid", MHA, metaimage())
    write("mha_short", MHA, metaimage()[:-5])
    write("mha_huge", MHA, metaimage(dims="100000 100000 100000"))
    write("mha_negative", MHA, metaimage(dims="4 -3 2"))
    write("mha_missing_dim", MHA, metaimage(dims="4"))
    write("mha_ndims_seven", MHA, metaimage(ndims=7, dims="2 2 2 2 2 2 2"))
    write("mha_ndims_zero", MHA, metaimage(ndims=0, dims=""))
    write("mha_bad_type", MHA, metaimage(element="MET_NOTATYPE"))
    write("mha_float", MHA, metaimage(element="MET_FLOAT", data=b"".join(
        struct.pack("<f", v) for v in LABELS)))
    write("mha_compressed_garbage", MHA, metaimage(extra="CompressedData = True\n"))
    write("mha_compressed", MHA, metaimage(extra="CompressedData = True\nCompressedDataSize = %d\n"
                                           % len(zlib.compress(LABELS)), data=zlib.compress(LABELS)))
    write("mha_spacing_zero", MHA, metaimage(extra="ElementSpacing = 0 0 0\n"))
    write("mha_channels", MHA, metaimage(extra="ElementNumberOfChannels = 3\n", data=LABELS * 3))
    write("mha_big_endian", MHA, metaimage(extra="BinaryDataByteOrderMSB = True\n",
                                           element="MET_SHORT", data=LABELS * 2))
    # MetaImage header with a data file (.mhd).
    write("mhd_valid", MHD, metaimage(dims="4 4 4", data_file="data.raw"))
    write("mhd_data_short", MHD, metaimage(dims="8 8 8", data_file="data.raw"))
    write("mhd_missing_data", MHD, metaimage(data_file="missing.raw"))
    write("mhd_data_directory", MHD, metaimage(data_file="."))
    write("mhd_list", MHD, metaimage(dims="4 4 4", data_file="LIST\ndata.raw"))
    # NRRD with its voxels (.nrrd).
    write("nrrd_valid", NRRD, nrrd())
    write("nrrd_short", NRRD, nrrd()[:-5])
    write("nrrd_huge", NRRD, nrrd(sizes="100000 100000 100000"))
    write("nrrd_negative", NRRD, nrrd(sizes="12 -2 1"))
    write("nrrd_small_first_axis", NRRD, nrrd(sizes="4 3 2"))
    write("nrrd_two_dimensional", NRRD, nrrd(dimension=2, sizes="12 2"))
    write("nrrd_four_dimensional", NRRD, nrrd(dimension=4, sizes="1 12 2 1"))
    write("nrrd_dimension_zero", NRRD, nrrd(dimension=0, sizes=""))
    write("nrrd_dimension_many", NRRD, nrrd(dimension=17, sizes=" ".join(["12"] + ["1"] * 16)))
    write("nrrd_bad_type", NRRD, nrrd(type_="complex"))
    write("nrrd_gzip", NRRD, nrrd(encoding="gzip", data=gzip.compress(LABELS, mtime=0)))
    write("nrrd_gzip_garbage", NRRD, nrrd(encoding="gzip"))
    write("nrrd_ascii", NRRD, nrrd(encoding="ascii", data=" ".join(
        str(v) for v in LABELS).encode()))
    write("nrrd_ascii_garbage", NRRD, nrrd(encoding="ascii", data=b"1 2 x y"))
    write("nrrd_hex", NRRD, nrrd(encoding="hex", data=LABELS.hex().encode()))
    write("nrrd_spacings", NRRD, nrrd(extra="spacings: nan 0 -1\n"))
    write("nrrd_directions", NRRD, nrrd(extra="space: left-posterior-superior\nspace directions:"
                                        " (0,0,0) (0,1,0) (0,0,nan)\n"))
    write("nrrd_endian", NRRD, nrrd(type_="short", extra="endian: big\n", data=LABELS * 2))
    write("nrrd_bad_magic", NRRD, b"NRRD9" + nrrd()[5:])
    # NRRD header with a data file (.nhdr).
    write("nhdr_valid", NHDR, nrrd(sizes="16 2 2", data_file="data.raw"))
    write("nhdr_data_short", NHDR, nrrd(sizes="16 4 4", data_file="data.raw"))
    write("nhdr_missing_data", NHDR, nrrd(data_file="missing.raw"))
    write("nhdr_skip", NHDR, nrrd(sizes="16 2 2", data_file="data.raw", extra="byte skip: 60\n"))
    # VTK XML image data, inline.
    write("vti_valid", VTI, vti())
    write("vti_too_few_values", VTI, vti(values="1 2 3"))
    write("vti_huge_extent", VTI, vti(extent="0 99999 0 99999 0 99999"))
    write("vti_inverted_extent", VTI, vti(extent="3 0 2 0 1 0"))
    write("vti_bad_type", VTI, vti(type_="Complex"))
    write("vti_float", VTI, vti(type_="Float32"))
    write("vti_two_components", VTI, vti(components=2))
    write("vti_truncated", VTI, vti(truncate=300))
    write("vti_binary_garbage", VTI, vti(fmt="binary", values="!!!not base64!!!"))
    write("vti_spacing_nan", VTI, vti(spacing="nan 0 -1"))
    write("vti_not_xml", VTI, b"\x00\x01\x02 this is not XML")


if __name__ == "__main__":
    main()
