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
put("nrrd", "gzip_ras.nrrd", nrrd.format(enc="gzip").encode() + gzip.compress(floats(12), mtime=0))
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
put("nifti_header", "compressed.nii", gzip.compress(bytes(h) + floats(8), mtime=0))

# OpenIGTLink: a 58-byte header and an IMAGE body (float32 and uint8, RAS and LPS).
vol = {"size": (3, 2, 2), "srow": [(1.5, 0, 0, -10), (0, 1.5, 0, 20), (0, 0, 2, 5)],
       "scalar": 10, "data": floats(12)}
put("igtl_image", "float32.igtl", igtl_client.message("IMAGE", "Doppler",
                                                      igtl_client.image_body(vol)))
vol8 = dict(vol, scalar=3, data=bytes(range(12)))
put("igtl_image", "uint8.igtl", igtl_client.message("IMAGE", "BMode",
                                                    igtl_client.image_body(vol8)))

# Volumes through read_volume (first byte: 0 .nii, 1 .nii.gz, 2 .mha, 3 .vti).
put("volume", "plain.nii", b"\0" + bytes(h) + floats(8))
put("volume", "compressed.nii.gz", b"\1" + gzip.compress(bytes(h) + floats(8), mtime=0))
mha = ("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
       "CompressedData = False\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nOffset = -10 20 5\n"
       "CenterOfRotation = 0 0 0\nAnatomicalOrientation = RAI\nElementSpacing = 1.5 1.5 2\n"
       "DimSize = 3 2 2\nElementType = MET_FLOAT\nElementDataFile = LOCAL\n")
put("volume", "image.mha", b"\2" + mha.encode() + floats(12))
vti = ('<VTKFile type="ImageData" version="0.1" byte_order="LittleEndian">\n'
       '<ImageData WholeExtent="0 2 0 1 0 1" Origin="-10 20 5" Spacing="1.5 1.5 2" '
       'Direction="1 0 0 0 1 0 0 0 1">\n<Piece Extent="0 2 0 1 0 1">\n<PointData Scalars="s">\n'
       '<DataArray type="Float32" Name="s" format="ascii">' +
       " ".join("%g" % (float(i % 7) - 1.5) for i in range(12)) +
       '</DataArray>\n</PointData>\n</Piece>\n</ImageData>\n</VTKFile>\n')
put("volume", "image.vti", b"\3" + vti.encode())

# VTK XML meshes and polylines (first byte: 0 mesh .vtu, 1 displacement .vtu, 2 skeleton .vtp,
# 3 surface .vtp, 4 footprint .vtp); ASCII and appended raw binary.
def vtu(extra_point_data=""):
    return ('<VTKFile type="UnstructuredGrid" version="0.1" byte_order="LittleEndian">\n'
            '<UnstructuredGrid><Piece NumberOfPoints="5" NumberOfCells="2">\n'
            '<PointData>' + extra_point_data + '</PointData>\n'
            '<CellData><DataArray type="Float64" Name="youngs_modulus" format="ascii">3 3'
            '</DataArray><DataArray type="Float64" Name="poisson_ratio" format="ascii">0.45 0.45'
            '</DataArray></CellData>\n<Points><DataArray type="Float64" NumberOfComponents="3" '
            'format="ascii">0 0 0 10 0 0 0 10 0 0 0 10 10 10 10</DataArray></Points>\n'
            '<Cells><DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 3 1 2 3 4'
            '</DataArray><DataArray type="Int64" Name="offsets" format="ascii">4 8</DataArray>'
            '<DataArray type="UInt8" Name="types" format="ascii">10 10</DataArray></Cells>\n'
            '</Piece></UnstructuredGrid></VTKFile>\n')
put("vtk_xml", "mesh.vtu", b"\0" + vtu().encode())
put("vtk_xml", "displacement.vtu", b"\1" + vtu(
    '<DataArray type="Float64" Name="displacement" NumberOfComponents="3" format="ascii">'
    '0 0 0 1 0 0 0 1 0 0 0 1 1 1 1</DataArray>').encode())
points = struct.pack("<9f", 0, 0, 0, 5, 0, 0, 10, 1, 0)
raw = lambda b: struct.pack("<I", len(b)) + b  # appended raw: a UInt32 byte count, the bytes
appended = raw(points) + raw(struct.pack("<3q", 0, 1, 2)) + raw(struct.pack("<q", 3)) + \
    raw(struct.pack("<3f", 1.0, 1.2, 0.8))
skeleton = ('<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian" header_type="UInt32">'
            '\n<PolyData><Piece NumberOfPoints="3" NumberOfLines="1">\n<PointData>'
            '<DataArray type="Float32" Name="radius" format="appended" offset="%d"/></PointData>\n'
            '<Points><DataArray type="Float32" NumberOfComponents="3" format="appended" '
            'offset="0"/></Points>\n<Lines><DataArray type="Int64" Name="connectivity" '
            'format="appended" offset="%d"/><DataArray type="Int64" Name="offsets" '
            'format="appended" offset="%d"/></Lines>\n</Piece></PolyData>\n'
            '<AppendedData encoding="raw">\n_' % (4 + 36 + 4 + 24 + 4 + 8, 4 + 36, 4 + 36 + 4 + 24))
put("vtk_xml", "skeleton.vtp", b"\2" + skeleton.encode() + appended + b"\n</AppendedData>\n</VTKFile>\n")
surface = ('<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">\n<PolyData>'
           '<Piece NumberOfPoints="4" NumberOfPolys="2">\n<Points><DataArray type="Float64" '
           'NumberOfComponents="3" format="ascii">0 0 0 10 0 0 0 10 0 10 10 0</DataArray></Points>\n'
           '<Polys><DataArray type="Int64" Name="connectivity" format="ascii">0 1 2 1 3 2'
           '</DataArray><DataArray type="Int64" Name="offsets" format="ascii">3 6</DataArray>'
           '</Polys>\n</Piece></PolyData></VTKFile>\n')
put("vtk_xml", "surface.vtp", b"\3" + surface.encode())
footprint = ('<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">\n<PolyData>'
             '<Piece NumberOfPoints="3" NumberOfVerts="3">\n<PointData><DataArray type="Float64" '
             'Name="normals" NumberOfComponents="3" format="ascii">0 0 1 0 0 1 0 0 1</DataArray>'
             '</PointData>\n<Points><DataArray type="Float64" NumberOfComponents="3" '
             'format="ascii">0 0 0 1 0 0 0 1 0</DataArray></Points>\n<Verts><DataArray '
             'type="Int64" Name="connectivity" format="ascii">0 1 2</DataArray><DataArray '
             'type="Int64" Name="offsets" format="ascii">1 2 3</DataArray></Verts>\n'
             '</Piece></PolyData></VTKFile>\n')
put("vtk_xml", "footprint.vtp", b"\4" + footprint.encode())

# Scene files (first byte: 0 a scene beside a one-tetrahedron mesh.vtu and fixed.csv, 1 the
# option overrides of prepare --scene-options).
scene = ('{"version": 1, "mesh": "mesh.vtu", "fixed": {"nodes": "fixed.csv"}, '
         '"craniotomy": {"centre_mm": [5, 5, 10], "radius_mm": 30.0}, '
         '"solver": {"max_iterations": 50}}')
put("scene", "scene.json", b"\0" + scene.encode())
put("scene", "options.json", b"\1" + b'{"craniotomy": {"radius_mm": 25}, "solver": {}}')

# The MODEL folder's manifest (as prepare writes it, shortened) and compliance cache.
put("model_manifest", "model.json",
    '{"format": "brainshift-model", "version": 1, "header_notes": [], '
    '"compliance": {"block_nodes": 2, "file": "compliance.bin", "strategy": "dense_block"}, '
    '"preop_grid": {"size": [4, 4, 4], "spacing_mm": [1, 1, 1], "origin_mm": [0, 0, 0], '
    '"direction": [[1, 0, 0], [0, 1, 0], [0, 0, 1]]}, "inputs": {}}')


def fnv1a(data):
    x = 1469598103934665603  # core/hash.hpp's offset basis (FNV's has one more digit; kept: format)
    for b in data:
        x = ((x ^ b) * 1099511628211) & 0xFFFFFFFFFFFFFFFF
    return x


nodes = [3, 7]
nb = 3 * len(nodes)
cache = b"BSCOMPL\0" + struct.pack("<IIQq", 1, 0, 1234567, len(nodes)) + \
    struct.pack("<%dq" % len(nodes), *nodes)
for j in range(nb):  # the upper triangle, column by column: (j, j) … (nb − 1, j)
    cache += struct.pack("<%dd" % (nb - j), *[(1.0 if i == j else 0.1) for i in range(j, nb)])
put("compliance_cache", "two_nodes.bin", cache + struct.pack("<Q", fnv1a(cache)))
print("corpora written under", os.path.join(HERE, "corpus"))
