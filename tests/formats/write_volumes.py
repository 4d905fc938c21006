#!/usr/bin/python3
"""Writes test volumes in every format ctlab reads, with independent writers (nibabel for
NIfTI, pydicom for DICOM, numpy plus the formats' text headers for NRRD and MetaImage, numpy for
raw), and a manifest of the answers for tests/test_formats.cpp.

The answer: a 5x4x3 "head" in the lab frame (i towards the patient's right, j from the face
backwards, k from the crown down) with lab value L(i, j, k) = 100 k + 10 j + i - 50 and spacing
0.5, 0.75, 2.0. Each file stores a*L + b (its own units) in one of the 48 axis orders and flips,
with the affine or directions that describe it; loading it must give L's layout back.

Usage: write_volumes.py FOLDER. Writes FOLDER/manifest.txt, one line per volume:
    PATH A B EXACT ORIENTED
EXACT = 1 when the values are whole numbers that fit int16 (the volume must keep them);
ORIENTED = 1 when the file carries an orientation. Exit 3 names a missing Python package.
"""
import gzip
import itertools
import os
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
    from pydicom.dataset import FileDataset, FileMetaDataset
    from pydicom.uid import ExplicitVRLittleEndian
except ImportError:
    missing.append("python3-pydicom")
if missing:
    print("missing " + " ".join(missing))
    sys.exit(3)

NX, NY, NZ = 5, 4, 3
SPACING = (0.5, 0.75, 2.0)
# Lab axes as world directions.
LAB_RAS = np.array([[1, 0, 0], [0, -1, 0], [0, 0, -1]], dtype=float)
LAB_LPS = np.array([[-1, 0, 0], [0, 1, 0], [0, 0, -1]], dtype=float)

i, j, k = np.meshgrid(np.arange(NX), np.arange(NY), np.arange(NZ), indexing="ij")
LAB = (100 * k + 10 * j + i - 50).astype(np.float64)  # indexed [i, j, k]

ORIENTATIONS = [(p, f) for p in itertools.permutations(range(3))
                for f in itertools.product((False, True), repeat=3)]  # 6 x 8 = 48


def in_file_order(values, order):
    """values[i, j, k] -> the array F[a0, a1, a2] whose file axis a is lab axis p[a]."""
    p, flips = order
    out = np.transpose(values, p)
    for a in range(3):
        if flips[a]:
            out = np.flip(out, axis=a)
    return np.ascontiguousarray(out)


def directions(order, lab):
    """Rows: the world direction (times spacing) of each file axis."""
    p, flips = order
    return np.array([(-1 if flips[a] else 1) * lab[p[a]] * SPACING[p[a]] for a in range(3)])


def tag(order):
    p, flips = order
    return "".join("ijk"[x] for x in p) + "_" + "".join("f" if x else "s" for x in flips)


def fortran_bytes(array, dtype, big=False):
    """The array's samples, first axis fastest, as bytes of dtype."""
    data = np.asfortranarray(array).astype(dtype)
    if big:
        data = data.astype(np.dtype(dtype).newbyteorder(">"))
    return data.tobytes(order="F")


manifest = []


def add(path, a, b, exact, oriented):
    manifest.append(f"{path} {a!r} {b!r} {int(exact)} {int(oriented)}")


def write_nifti(folder):
    # Every orientation, as int16 of the lab values: sform for even ones, qform for odd.
    for n, order in enumerate(ORIENTATIONS):
        data = in_file_order(LAB, order).astype(np.int16)
        affine = np.eye(4)
        affine[:3, :3] = directions(order, LAB_RAS).T  # columns = file axes
        affine[:3, 3] = (10, -20, 30)
        image = nibabel.Nifti1Image(data, None)
        if n % 2 == 0:
            image.set_sform(affine, code=1)
            image.set_qform(None, code=0)
        else:
            image.set_qform(affine, code=1)
            image.set_sform(None, code=0)
        name = f"nifti_{tag(order)}.nii" + (".gz" if n % 3 == 0 else "")
        nibabel.save(image, os.path.join(folder, name))
        add(name, 1, 0, True, True)
    # Types and scaling, in one orientation (RAS as stored: j and k flipped).
    order = ((0, 1, 2), (False, True, True))
    affine = np.eye(4)
    affine[:3, :3] = directions(order, LAB_RAS).T
    cases = [("uint8", np.uint8, 1, 50, None), ("int8", np.int8, 1, -60, None),
             ("uint16", np.uint16, 100, 30000, None), ("float32", np.float32, 0.01, 0.5, None),
             ("float64", np.float64, 0.001, -2.25, None), ("int16_scaled", np.int16, 2.5, 10, (2.5, 10))]
    for name, dtype, a, b, scaling in cases:
        if scaling:
            stored = in_file_order(LAB, order).astype(dtype)  # file value = 2.5 * L + 10
        else:
            stored = in_file_order(a * LAB + b, order).astype(dtype)
        image = nibabel.Nifti1Image(stored, affine)
        image.set_qform(affine, code=1)
        if scaling:
            image.header.set_slope_inter(*scaling)
        path = f"nifti_type_{name}.nii"
        nibabel.save(image, os.path.join(folder, path))
        add(path, a, b, a == 1 and float(b).is_integer() and dtype is not np.uint16, True)
    # No orientation at all: taken as stored (the lab order, no flips).
    header = nibabel.Nifti1Header()
    header.set_data_dtype(np.int16)
    image = nibabel.Nifti1Image(LAB.astype(np.int16), None, header)
    image.header.set_zooms(SPACING)
    image.header["sform_code"] = 0
    image.header["qform_code"] = 0
    nibabel.save(image, os.path.join(folder, "nifti_unoriented.nii"))
    add("nifti_unoriented.nii", 1, 0, True, False)


NRRD_TYPES = {"int16": ("short", np.int16), "uint8": ("uchar", np.uint8),
              "uint16": ("ushort", np.uint16), "float32": ("float", np.float32)}


def write_nrrd(folder):
    chosen = ORIENTATIONS[::5]  # ten orientations of the 48
    for n, order in enumerate(chosen):
        lps = n % 2 == 1
        dirs = directions(order, LAB_LPS if lps else LAB_RAS)
        type_name, a, b = [("int16", 1, 0), ("uint16", 100, 30000), ("float32", 0.01, 0.5),
                           ("uint8", 1, 50)][n % 4]
        nrrd_type, dtype = NRRD_TYPES[type_name]
        data = in_file_order(a * LAB + b, order)
        big = n % 3 == 1
        encoding = "gzip" if n % 3 == 2 else "raw"
        payload = fortran_bytes(data, dtype, big)
        if encoding == "gzip":
            payload = gzip.compress(payload)
        space = "left-posterior-superior" if lps else "right-anterior-superior"
        header = ["NRRD0004", f"type: {nrrd_type}", "dimension: 3",
                  "sizes: " + " ".join(str(s) for s in data.shape),
                  f"space: {space}",
                  "space directions: " + " ".join("(" + ",".join(repr(float(x)) for x in d) + ")"
                                                  for d in dirs),
                  f"encoding: {encoding}", "endian: " + ("big" if big else "little")]
        detached = n % 4 == 3
        name = f"nrrd_{tag(order)}_{type_name}" + (".nhdr" if detached else ".nrrd")
        if detached:
            header.append(f"data file: {name[:-5]}.data")
            with open(os.path.join(folder, name[:-5] + ".data"), "wb") as out:
                out.write(payload)
            with open(os.path.join(folder, name), "w") as out:
                out.write("\n".join(header) + "\n")
        else:
            with open(os.path.join(folder, name), "wb") as out:
                out.write(("\n".join(header) + "\n\n").encode() + payload)
        add(name, a, b, type_name in ("int16", "uint8"), True)
    # Plain spacings, no space: as stored.
    header = ["NRRD0004", "type: short", "dimension: 3", f"sizes: {NX} {NY} {NZ}",
              "spacings: 0.5 0.75 2", "encoding: raw", "endian: little", ""]
    with open(os.path.join(folder, "nrrd_spacings.nrrd"), "wb") as out:
        out.write(("\n".join(header) + "\n").encode() + fortran_bytes(LAB, np.int16))
    add("nrrd_spacings.nrrd", 1, 0, True, False)


MET_TYPES = {"int16": ("MET_SHORT", np.int16), "uint8": ("MET_UCHAR", np.uint8),
             "uint16": ("MET_USHORT", np.uint16), "float32": ("MET_FLOAT", np.float32),
             "int8": ("MET_CHAR", np.int8)}


def write_metaimage(folder):
    chosen = ORIENTATIONS[1::6]  # eight orientations
    for n, order in enumerate(chosen):
        dirs = directions(order, LAB_LPS)
        type_name, a, b = [("int16", 1, 0), ("uint16", 100, 30000), ("float32", 0.01, 0.5),
                           ("int8", 1, -60)][n % 4]
        met_type, dtype = MET_TYPES[type_name]
        data = in_file_order(a * LAB + b, order)
        big = n % 2 == 1
        payload = fortran_bytes(data, dtype, big)
        compressed = n % 3 == 1
        if compressed:
            payload = zlib.compress(payload)
        spacing = [float(np.linalg.norm(d)) for d in dirs]
        matrix = [x / s for d, s in zip(dirs, spacing) for x in d]
        kind = ["mha", "mhd", "mhd"][n % 3]
        name = f"meta_{tag(order)}_{type_name}.{kind}"
        header = ["ObjectType = Image", "NDims = 3", "BinaryData = True",
                  "BinaryDataByteOrderMSB = " + ("True" if big else "False"),
                  "CompressedData = " + ("True" if compressed else "False"),
                  "TransformMatrix = " + " ".join(repr(x) for x in matrix),
                  "Offset = 0 0 0", "AnatomicalOrientation = ???",
                  "ElementSpacing = " + " ".join(repr(s) for s in spacing),
                  "DimSize = " + " ".join(str(s) for s in data.shape),
                  f"ElementType = {met_type}"]
        if kind == "mha":
            header.append("ElementDataFile = LOCAL")
            with open(os.path.join(folder, name), "wb") as out:
                out.write(("\n".join(header) + "\n").encode() + payload)
        else:
            data_name = name[:-4] + (".zraw" if compressed else ".raw")
            header.append(f"ElementDataFile = {data_name}")
            with open(os.path.join(folder, name), "w") as out:
                out.write("\n".join(header) + "\n")
            with open(os.path.join(folder, data_name), "wb") as out:
                out.write(payload)
        add(name, a, b, type_name in ("int16", "int8"), True)


def write_dicom(folder):
    chosen = [ORIENTATIONS[0], ORIENTATIONS[7], ORIENTATIONS[19], ORIENTATIONS[42]]
    for n, order in enumerate(chosen):
        series = f"dicom_{tag(order)}"
        os.makedirs(os.path.join(folder, series))
        dirs = directions(order, LAB_LPS)
        # Stored uint16 = L + 1074 with intercept -1124 (file = L - 50 + ...): CT-like.
        stored_values = in_file_order(LAB + 1074, order).astype(np.uint16)  # [col, row, slice]
        uid = pydicom.uid.generate_uid()
        slices = stored_values.shape[2]
        for s in range(slices):
            meta = FileMetaDataset()
            meta.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
            meta.MediaStorageSOPInstanceUID = pydicom.uid.generate_uid()
            meta.TransferSyntaxUID = ExplicitVRLittleEndian
            # Names and instance numbers in the opposite order: sorting must use positions.
            path = os.path.join(folder, series, f"slice{slices - 1 - s:03d}.dcm")
            ds = FileDataset(path, {}, file_meta=meta, preamble=b"\0" * 128)
            ds.is_little_endian = True
            ds.is_implicit_VR = False
            ds.SOPClassUID = meta.MediaStorageSOPClassUID
            ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
            ds.Modality = "CT"
            ds.SeriesInstanceUID = uid
            ds.StudyInstanceUID = pydicom.uid.generate_uid()
            ds.InstanceNumber = slices - s
            ds.ImageOrientationPatient = [float(x) for x in
                                          list(dirs[0] / np.linalg.norm(dirs[0])) +
                                          list(dirs[1] / np.linalg.norm(dirs[1]))]
            origin = np.array([5.0, -7.0, 11.0]) + s * dirs[2]
            ds.ImagePositionPatient = [float(x) for x in origin]
            ds.PixelSpacing = [float(np.linalg.norm(dirs[1])), float(np.linalg.norm(dirs[0]))]
            ds.SliceThickness = float(np.linalg.norm(dirs[2]))
            ds.Rows, ds.Columns = stored_values.shape[1], stored_values.shape[0]
            ds.SamplesPerPixel = 1
            ds.PhotometricInterpretation = "MONOCHROME2"
            ds.BitsAllocated = 16
            ds.BitsStored = 16
            ds.HighBit = 15
            ds.PixelRepresentation = 0
            ds.RescaleSlope = 1
            ds.RescaleIntercept = -1124
            ds.PixelData = np.ascontiguousarray(stored_values[:, :, s].T).tobytes()
            ds.save_as(path, write_like_original=False)
        add(series, 1, -50, True, True)


def write_raw(folder):
    for type_name, dtype, a, b, exact in [("uint8", np.uint8, 1, 50, True),
                                          ("int8", np.int8, 1, -60, True),
                                          ("uint16", np.uint16, 100, 30000, False),
                                          ("int16", np.int16, 1, 0, True),
                                          ("float32", np.float32, 0.01, 0.5, False)]:
        name = f"head_{NX}x{NY}x{NZ}_{type_name}.raw"
        with open(os.path.join(folder, name), "wb") as out:
            out.write(fortran_bytes(a * LAB + b, dtype))
        add(name, a, b, exact, False)


def main():
    folder = sys.argv[1]
    os.makedirs(folder, exist_ok=True)
    write_nifti(folder)
    write_nrrd(folder)
    write_metaimage(folder)
    write_dicom(folder)
    write_raw(folder)
    with open(os.path.join(folder, "manifest.txt"), "w") as out:
        out.write("\n".join(manifest) + "\n")


main()
