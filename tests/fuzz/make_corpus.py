#!/usr/bin/env python3
"""Writes the seed corpora of the fuzz targets (tests/fuzz/corpus/<target>/): small valid files of
each format, as the phantoms and the other programs write them, plus a few edge cases. Standard
library only; deterministic. Run from anywhere: python3 tests/fuzz/make_corpus.py"""
import gzip
import os
import struct
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "apps"))
import igtl_client  # noqa: E402  (the test client's message packing, written from the protocol)


def put(target, name, data):
    folder = os.path.join(HERE, "corpus", target)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def floats(n):
    return struct.pack("<%df" % n, *[float(i % 7) - 1.5 for i in range(n)])


# NRRD: raw and gzip, RAS and LPS, a 4-D vector volume, big-endian shorts.
nrrd = ("NRRD0004\ntype: float\ndimension: 3\nspace: right-anterior-superior\nsizes: 3 2 2\n"
        "space directions: (1.5,0,0) (0,1,0) (0,0,2)\nkinds: domain domain domain\n"
        "endian: little\nencoding: {enc}\nspace origin: (-10,20,5)\n\n")
put("nrrd", "raw_ras.nrrd", nrrd.format(enc="raw").encode() + floats(12))
put("nrrd", "gzip_ras.nrrd", nrrd.format(enc="gzip").encode() + gzip.compress(floats(12)))
put("nrrd", "lps_oblique.nrrd",
    "NRRD0004\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: 2 2 2\n"
    "space directions: (0.8660254,0.5,0) (-0.5,0.8660254,0) (0,0,1)\nendian: little\n"
    "encoding: raw\nspace origin: (1,2,3)\n\n".encode() + floats(8))
put("nrrd", "vectors.nrrd",
    "NRRD0004\ntype: float\ndimension: 4\nspace: left-posterior-superior\nsizes: 3 2 1 1\n"
    "space directions: none (1,0,0) (0,1,0) (0,0,1)\nkinds: vector domain domain domain\n"
    "measurement frame: (1,0,0) (0,1,0) (0,0,1)\nendian: little\nencoding: raw\n"
    "space origin: (0,0,0)\n\n".encode() + floats(6))
put("nrrd", "short_big.nrrd",
    "NRRD0004\ntype: short\ndimension: 3\nsizes: 2 2 1\nspacings: 1 1 1\nendian: big\n"
    "encoding: raw\n\n".encode() + struct.pack(">4h", 1, -2, 300, -400))

# Landmarks: the first byte picks the format (0 .tag, 1 .fcsv, 2 .mrk.json, 3 .csv).
tag = ("MNI Tag Point File\nVolumes = 2;\n% comment\n\nPoints =\n"
       " 1.5 -2 30 2 -1.5 31 \"1\"\n 10 20 -5 11 19 -4 \"2\";\n")
put("landmarks", "pairs.tag", b"\0" + tag.encode())
fcsv = ("# Markups fiducial file version = 4.11\n# CoordinateSystem = LPS\n"
        "# columns = id,x,y,z,ow,ox,oy,oz,vis,sel,lock,label,desc,associatedNodeID\n"
        "vtkMRMLMarkupsFiducialNode_0,-1,2,3,0,0,0,1,1,1,0,A,,\n"
        "vtkMRMLMarkupsFiducialNode_1,4,5,6,0,0,0,1,1,1,0,B,,\n")
put("landmarks", "slicer.fcsv", b"\1" + fcsv.encode())
mrk = ('{"@schema": "https://raw.githubusercontent.com/slicer/slicer/master/Modules/Loadable/'
       'Markups/Resources/Schema/markups-schema-v1.0.3.json#", "markups": [{"type": "Fiducial", '
       '"coordinateSystem": "LPS", "controlPoints": [{"id": "1", "label": "A", "position": '
       '[1.0, 2.0, 3.0]}, {"id": "2", "label": "B", "position": [-4.0, 5.5, 6.0]}]}]}')
put("landmarks", "slicer.mrk.json", b"\2" + mrk.encode())
put("landmarks", "points.csv", b"\3" + b"id,x,y,z\n1,0.5,1,2\n2,-3,4,5e1\n")

# PLUS sequence: two 3x2 uchar frames with ProbeToTracker transforms, one INVALID.
seq = ("ObjectType = Image\nNDims = 3\nAnatomicalOrientation = RAI\nBinaryData = True\n"
       "BinaryDataByteOrderMSB = False\nCompressedData = False\nDimSize = 3 2 2\n"
       "ElementNumberOfChannels = 1\nElementSpacing = 0.5 0.5 1\nElementType = MET_UCHAR\n"
       "Offset = 0 0 0\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nUltrasoundImageOrientation = MF\n"
       "UltrasoundImageType = BRIGHTNESS\n")
for n, status in enumerate(["OK", "INVALID"]):
    p = "Seq_Frame%04d_" % n
    seq += (p + "FrameNumber = %d\n" % n + p +
            "ProbeToTrackerTransform = 1 0 0 %d 0 1 0 0 0 0 1 0 0 0 0 1\n" % n +
            p + "ProbeToTrackerTransformStatus = %s\n" % status + p + "Timestamp = %g\n" % (0.05 * n)
            + p + "ImageStatus = OK\n")
seq += "ElementDataFile = LOCAL\n"
put("plus_sequence", "two_frames.seq.mha", seq.encode() + bytes(range(12)))

# NIfTI-1: a 348-byte header (sform) and 2x2x2 floats, plain and gzip.
h = bytearray(352)
struct.pack_into("<i", h, 0, 348)
struct.pack_into("<8h", h, 40, 3, 2, 2, 2, 1, 1, 1, 1)
struct.pack_into("<hh", h, 70, 16, 32)
struct.pack_into("<8f", h, 76, 1, 1.5, 1.5, 2, 1, 1, 1, 1)
struct.pack_into("<f", h, 108, 352.0)
struct.pack_into("<f", h, 112, 1.0)
struct.pack_into("<hh", h, 252, 1, 2)
struct.pack_into("<12f", h, 280, 1.5, 0, 0, -10, 0, 1.5, 0, 20, 0, 0, 2, 5)
h[344:348] = b"n+1\0"
put("nifti_header", "plain.nii", bytes(h) + floats(8))
put("nifti_header", "compressed.nii", gzip.compress(bytes(h) + floats(8)))

# OpenIGTLink: a 58-byte header and an IMAGE body (float32 and uint8, RAS and LPS).
vol = {"size": (3, 2, 2), "srow": [(1.5, 0, 0, -10), (0, 1.5, 0, 20), (0, 0, 2, 5)],
       "scalar": 10, "data": floats(12)}
put("igtl_image", "float32.igtl", igtl_client.message("IMAGE", "Doppler",
                                                      igtl_client.image_body(vol)))
vol8 = dict(vol, scalar=3, data=bytes(range(12)))
put("igtl_image", "uint8.igtl", igtl_client.message("IMAGE", "BMode",
                                                    igtl_client.image_body(vol8)))
print("corpora written under", os.path.join(HERE, "corpus"))
