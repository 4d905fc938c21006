#!/usr/bin/python3
"""Writes small hostile volume files, with independent writers (nibabel for NIfTI, pydicom for
DICOM, numpy and hand-made header bytes for NRRD, MetaImage and raw), for
tests/hostile_files_test.sh and tests/test_hostile_files.cpp.

Usage: write_hostile.py FOLDER [--big]. Writes FOLDER/cases.txt, one line per file that a
loader must refuse:  PATH|A PART OF THE ONE-LINE MESSAGE
and FOLDER/good.txt, one line per file that must load (the same shapes, undamaged).
--big also writes the memory test's files (FOLDER/big_*: 256x256x64, float32 and int16, each
format, plus a .nii.gz with 64 MiB of extension before its data), listed in FOLDER/big.txt.
Exit 3 names a missing Python package.
"""
import gzip
import os
import struct
import sys
import zlib

missing = []
try:
    import numpy as np
except ImportError:
    missing.append("python3-numpy")
try:
    import nibabel
except ImportError:
    missing.append("python3-nibabel")
try:
    import pydicom
    import pydicom.encaps
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian
except ImportError:
    missing.append("python3-pydicom")
if missing:
    print("missing " + " ".join(missing))
    sys.exit(3)

FOLDER = sys.argv[1]
cases = []  # (name, expected part of the message)
good = []


def path(name):
    return os.path.join(FOLDER, name)


def refuse(name, says):
    cases.append((name, says))


def write(name, data):
    with open(path(name), "wb") as out:
        out.write(data)


# The lab order, as stored: NIfTI's RAS with j and k flipped (no turn on loading).
AS_STORED = np.diag([1.0, -1.0, -1.0, 1.0])
values = (np.arange(5 * 4 * 3).reshape((5, 4, 3), order="F") - 20).astype(np.int16)


def nifti(name, data=values, affine=AS_STORED, pair=False):
    image = (nibabel.Nifti1Pair if pair else nibabel.Nifti1Image)(data, affine)
    nibabel.save(image, path(name))


def patch(name, offset, fmt, *numbers):
    with open(path(name), "r+b") as f:
        f.seek(offset)
        f.write(struct.pack("<" + fmt, *numbers))


def write_nifti():
    nifti("good.nii")
    good.append("good.nii")
    nifti("good_pair.hdr", pair=True)
    good.append("good_pair.hdr")
    nifti("good.nii.gz")
    good.append("good.nii.gz")
    # A .img short by 10 bytes; one missing; a .nii.gz cut in half.
    nifti("short_pair.hdr", pair=True)
    with open(path("short_pair.img"), "r+b") as f:
        f.truncate(os.path.getsize(path("short_pair.img")) - 10)
    refuse("short_pair.hdr", "its header needs exactly")
    nifti("lonely.hdr", pair=True)
    os.remove(path("lonely.img"))
    refuse("lonely.hdr", "is missing")
    nifti("cut.nii.gz")
    packed = open(path("cut.nii.gz"), "rb").read()
    write("cut.nii.gz", packed[: len(packed) * 2 // 3])
    refuse("cut.nii.gz", "cut short")
    # A .nii with 9 bytes too many.
    nifti("long.nii")
    with open(path("long.nii"), "ab") as f:
        f.write(b"\0" * 9)
    refuse("long.nii", "its header needs exactly")
    # dim[2] = 0 (dim[] starts at byte 40: dim[0], dim[1], dim[2] ...).
    nifti("zero_dim.nii")
    patch("zero_dim.nii", 44, "h", 0)
    refuse("zero_dim.nii", "dim[2] = 0")
    # scl_slope 2, scl_inter NaN (bytes 112 and 116).
    nifti("nan_inter.nii")
    patch("nan_inter.nii", 112, "ff", 2.0, float("nan"))
    refuse("nan_inter.nii", "scl_inter is NaN")
    # An sform whose second and third columns point the same way.
    parallel = np.diag([1.0, 1.0, 1.0, 1.0])
    parallel[:3, 2] = (0.0, 2.0, 0.0)
    nifti("parallel_sform.nii", affine=parallel)
    refuse("parallel_sform.nii", "file axes 2 and 3 the same direction")
    # A .nii.gz whose vox_offset claims far more than the file can unpack to.
    nifti("bomb_offset.nii.gz")
    raw = gzip.decompress(open(path("bomb_offset.nii.gz"), "rb").read())
    raw = raw[:108] + struct.pack("<f", float(1 << 30)) + raw[112:]
    write("bomb_offset.nii.gz", gzip.compress(raw))
    refuse("bomb_offset.nii.gz", "unpacked")


def nrrd_header(fields):
    return ("NRRD0004\n" + "".join(f"{k}: {v}\n" for k, v in fields)).encode()


def write_nrrd():
    base = [("type", "short"), ("dimension", 3), ("sizes", "5 4 3"), ("endian", "little")]
    data = values.tobytes(order="F")
    write("good.nrrd", nrrd_header(base + [("encoding", "raw")]) + b"\n" + data)
    good.append("good.nrrd")
    write("good_gz.nrrd", nrrd_header(base + [("encoding", "gzip")]) + b"\n" + gzip.compress(data))
    good.append("good_gz.nrrd")
    write("detached.raw", data)
    write("good_detached.nhdr", nrrd_header(base + [("encoding", "raw"),
                                                    ("data file", "detached.raw")]))
    good.append("good_detached.nhdr")
    # Detached data short by 3 bytes.
    write("short_data.raw", data[:-3])
    write("short_detached.nhdr", nrrd_header(base + [("encoding", "raw"),
                                                     ("data file", "short_data.raw")]))
    refuse("short_detached.nhdr", "its header needs exactly")
    # 200 bytes of gzip claiming 1024^3 voxels.
    write("bomb.nrrd", nrrd_header([("type", "short"), ("dimension", 3),
                                    ("sizes", "1024 1024 1024"), ("endian", "little"),
                                    ("encoding", "gzip")]) + b"\n" + gzip.compress(b"\0" * 4096))
    refuse("bomb.nrrd", "ends after 4096 bytes")
    # gzip holding more than the volume.
    write("long_gz.nrrd", nrrd_header(base + [("encoding", "gzip")]) + b"\n" +
          gzip.compress(data + b"\0\0"))
    refuse("long_gz.nrrd", "holds more than the 120 bytes")
    # The first axis is colour: three values per voxel, not a grey volume three voxels wide.
    write("colour.nrrd", nrrd_header([("type", "uchar"), ("dimension", 3), ("sizes", "3 4 5"),
                                      ("kinds", "RGB-color domain domain"), ("encoding", "raw")])
          + b"\n" + bytes(60))
    refuse("colour.nrrd", "kind \"RGB-color\"")
    # Space directions with two parallel axes.
    write("parallel.nrrd", nrrd_header(base + [
        ("space", "left-posterior-superior"),
        ("space directions", "(1,0,0) (0,1,0) (0,2,0)"), ("encoding", "raw")]) + b"\n" + data)
    refuse("parallel.nrrd", "file axes 2 and 3 the same direction")
    # A header line that never ends (2 MiB of it).
    write("endless.nrrd", b"NRRD0004\ntype: short\n# " + b"x" * (2 << 20))
    refuse("endless.nrrd", "no empty line ends the header")


def mha(fields, data):
    text = "".join(f"{k} = {v}\n" for k, v in fields)
    return text.encode() + data


def write_metaimage():
    base = [("ObjectType", "Image"), ("NDims", 3), ("DimSize", "5 4 3"),
            ("ElementType", "MET_SHORT")]
    data = values.tobytes(order="F")
    write("good.mha", mha(base + [("ElementDataFile", "LOCAL")], data))
    good.append("good.mha")
    write("good_z.mha", mha(base + [("CompressedData", "True"), ("ElementDataFile", "LOCAL")],
                            zlib.compress(data)))
    good.append("good_z.mha")
    write("long_z.mha", mha(base + [("CompressedData", "True"), ("ElementDataFile", "LOCAL")],
                            zlib.compress(data + b"\0" * 8)))
    refuse("long_z.mha", "holds more than the 120 bytes")
    write("short_z.mha", mha(base + [("CompressedData", "True"), ("ElementDataFile", "LOCAL")],
                             zlib.compress(data[:100])))
    refuse("short_z.mha", "ends after 100 bytes")
    write("bomb_z.mha", mha([("NDims", 3), ("DimSize", "1024 1024 1024"),
                             ("ElementType", "MET_SHORT"), ("CompressedData", "True"),
                             ("ElementDataFile", "LOCAL")], zlib.compress(b"\0" * 4096)))
    refuse("bomb_z.mha", "ends after 4096 bytes")
    # A 3 GiB sparse data file for a 120-byte volume: refused by its size, never read.
    with open(path("huge.raw"), "wb") as f:
        f.truncate(3 << 30)
    write("huge_data.mhd", mha(base + [("ElementDataFile", "huge.raw")], b""))
    refuse("huge_data.mhd", "the data has 3221225472 bytes, expected exactly 120")
    # A 3 GiB sparse .mha with no newline: only its first 64 KiB are looked at.
    with open(path("no_newline.mha"), "wb") as f:
        f.write(b"NDims = 3 ")
        f.truncate(3 << 30)
    refuse("no_newline.mha", "in the first 64 KiB")
    # Two parallel axes in TransformMatrix.
    write("parallel.mha", mha(base + [("TransformMatrix", "1 0 0 1 0 0 0 0 1"),
                                      ("ElementDataFile", "LOCAL")], data))
    refuse("parallel.mha", "file axes 1 and 2 the same direction")


def dicom_series(name, positions, bits_allocated=16, cut=0, slope=1):
    os.makedirs(path(name))
    uid = pydicom.uid.generate_uid()
    for s, z in enumerate(positions):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        meta.MediaStorageSOPInstanceUID = pydicom.uid.generate_uid()
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        file = os.path.join(path(name), f"slice{s:03d}.dcm")
        ds = FileDataset(file, {}, file_meta=meta, preamble=b"\0" * 128)
        ds.is_little_endian = True
        ds.is_implicit_VR = False
        ds.SOPClassUID = meta.MediaStorageSOPClassUID
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.Modality = "CT"
        ds.SeriesInstanceUID = uid
        ds.ImageOrientationPatient = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
        ds.ImagePositionPatient = [0.0, 0.0, float(z)]
        ds.PixelSpacing = [1.0, 1.0]
        ds.Rows, ds.Columns = 4, 5
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated = bits_allocated
        ds.BitsStored = 12
        ds.HighBit = 11
        ds.PixelRepresentation = 0
        ds.RescaleSlope = slope
        ds.RescaleIntercept = -1024
        pixels = (np.arange(20, dtype=np.uint16) + 100 * s).tobytes()
        ds.PixelData = pixels[: len(pixels) - cut] if cut else pixels
        ds.save_as(file, write_like_original=False)


def write_bad_jpeg(name):
    """One slice whose encapsulated JPEG Baseline frame has no scan: libjpeg prints its own
    complaint, which must end up quoted in our one line, not on a line of its own."""
    os.makedirs(path(name))
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
    meta.MediaStorageSOPInstanceUID = pydicom.uid.generate_uid()
    meta.TransferSyntaxUID = pydicom.uid.JPEGBaseline8Bit
    file = os.path.join(path(name), "slice.dcm")
    ds = FileDataset(file, {}, file_meta=meta, preamble=b"\0" * 128)
    ds.is_little_endian = True
    ds.is_implicit_VR = False
    ds.SOPClassUID = meta.MediaStorageSOPClassUID
    ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
    ds.Modality = "CT"
    ds.SeriesInstanceUID = pydicom.uid.generate_uid()
    ds.ImageOrientationPatient = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]
    ds.ImagePositionPatient = [0.0, 0.0, 0.0]
    ds.PixelSpacing = [1.0, 1.0]
    ds.Rows, ds.Columns = 8, 8
    ds.SamplesPerPixel = 1
    ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 8, 8, 7, 0
    # SOI, APP0 (JFIF), a quantisation table, a frame header, then junk and EOI: no SOS.
    frame = (bytes([0xFF, 0xD8, 0xFF, 0xE0, 0, 16]) + b"JFIF\0" + bytes(9) +
             bytes([0xFF, 0xDB, 0, 67, 0]) + bytes(range(64)) +
             bytes([0xFF, 0xC0, 0, 11, 8, 0, 8, 0, 8, 1, 1, 0x11, 0]) + b"\x12\x34junk" +
             bytes([0xFF, 0xD9]))
    ds.PixelData = pydicom.encaps.encapsulate([frame])
    ds["PixelData"].is_undefined_length = True
    ds.save_as(file, write_like_original=False)


def write_dicom():
    dicom_series("dicom_good", [0, 2, 4, 6])
    good.append("dicom_good")
    dicom_series("dicom_missing_slice", [0, 2, 6, 8])
    refuse("dicom_missing_slice", "a slice is missing")
    dicom_series("dicom_short_pixels", [0, 2, 4], cut=6)
    refuse("dicom_short_pixels", "PixelData has 34 bytes")
    dicom_series("dicom_bits12", [0, 2, 4], bits_allocated=12)
    refuse("dicom_bits12", "BitsAllocated 12")
    write_bad_jpeg("dicom_bad_jpeg")
    refuse("dicom_bad_jpeg", "GDCM could not decode its pixels (it said: ")


def write_big():
    """256x256x64: an int16 volume of 8 MiB; float32 files hold 16 MiB of data."""
    shape = (256, 256, 64)
    ramp = (np.arange(np.prod(shape)) % 3000).reshape(shape, order="F")
    floats = (ramp * 0.5).astype(np.float32)
    shorts = ramp.astype(np.int16)
    big = []
    nibabel.save(nibabel.Nifti1Image(floats, AS_STORED), path("big_float.nii.gz"))
    big.append("big_float.nii.gz")
    nibabel.save(nibabel.Nifti1Pair(floats, AS_STORED), path("big_pair.hdr"))
    big.append("big_pair.hdr")
    # 64 MiB of extension (zeros, a few kB of gzip) before the data: skipped, never kept.
    nibabel.save(nibabel.Nifti1Image(shorts, AS_STORED), path("big_ext.nii"))
    raw = open(path("big_ext.nii"), "rb").read()
    extension = 64 << 20
    header = bytearray(raw[:348])
    header[108:112] = struct.pack("<f", float(352 + extension))
    ext = struct.pack("<4B", 1, 0, 0, 0) + struct.pack("<ii", extension, 0) + \
        b"\0" * (extension - 8)
    with gzip.open(path("big_ext.nii.gz"), "wb", compresslevel=1) as f:
        f.write(bytes(header) + ext + raw[352:])
    os.remove(path("big_ext.nii"))
    big.append("big_ext.nii.gz")
    sizes = "256 256 64"
    write("big_gz.nrrd", nrrd_header([("type", "float"), ("dimension", 3), ("sizes", sizes),
                                      ("endian", "little"), ("encoding", "gzip")]) + b"\n" +
          gzip.compress(floats.tobytes(order="F"), 1))
    big.append("big_gz.nrrd")
    write("big_float.raw", floats.tobytes(order="F"))
    write("big_detached.nhdr", nrrd_header([("type", "float"), ("dimension", 3),
                                            ("sizes", sizes), ("endian", "little"),
                                            ("encoding", "raw"), ("data file", "big_float.raw")]))
    big.append("big_detached.nhdr")
    write("big_z.mha", mha([("NDims", 3), ("DimSize", sizes), ("ElementType", "MET_FLOAT"),
                            ("CompressedData", "True"), ("ElementDataFile", "LOCAL")],
                           zlib.compress(floats.tobytes(order="F"), 1)))
    big.append("big_z.mha")
    write("big_raw.mhd", mha([("NDims", 3), ("DimSize", sizes), ("ElementType", "MET_FLOAT"),
                              ("ElementDataFile", "big_float.raw")], b""))
    big.append("big_raw.mhd")
    os.link(path("big_float.raw"), path("big_256x256x64_float32.raw"))
    big.append("big_256x256x64_float32.raw")
    with open(path("big.txt"), "w") as f:
        f.write("".join(name + "\n" for name in big))


def main():
    os.makedirs(FOLDER, exist_ok=True)
    write_nifti()
    write_nrrd()
    write_metaimage()
    write_dicom()
    if "--big" in sys.argv[2:]:
        write_big()
    with open(path("cases.txt"), "w") as f:
        f.write("".join(f"{name}|{says}\n" for name, says in cases))
    with open(path("good.txt"), "w") as f:
        f.write("".join(name + "\n" for name in good))


main()
