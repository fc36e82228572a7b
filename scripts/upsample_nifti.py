#!/usr/bin/env python3
"""Nearest-neighbour x2 per axis upsampling of a float32 NIfTI-1 .nii.gz (same world extent):
each voxel becomes 2x2x2 voxels of half the spacing, the origin moves by a quarter voxel.
Makes the 16 M-voxel power Doppler of docs/history/BENCHMARKS_NOTEBOOK.md ("The intra-operative path under
2 s") from the demo's (165x165x76 -> 330x330x152). Standard library only.
usage: scripts/upsample_nifti.py P/intraop/doppler.nii.gz D16.nii.gz"""
import gzip, struct, sys
src, dst = sys.argv[1], sys.argv[2]
b = gzip.open(src).read()
h = bytearray(b[:348]); off = int(struct.unpack('<f', h[108:112])[0])
dims = list(struct.unpack('<8h', h[40:56])); nx, ny, nz = dims[1:4]
assert struct.unpack('<h', h[70:72])[0] == 16, 'float32 only'
data = b[off:off + 4 * nx * ny * nz]
pix = list(struct.unpack('<8f', h[76:108]))
srow = list(struct.unpack('<12f', h[280:328]))
# old voxel centre i covers new centres 2i and 2i+1 at old index i -/+ 1/4: origin moves by
# -1/4 of each (spacing-scaled) axis.
shift = [-0.25 * (srow[4*r] + srow[4*r+1] + srow[4*r+2]) for r in range(3)]
for r in range(3):
    for c in range(3): srow[4*r+c] *= 0.5
    srow[4*r+3] += shift[r]
q = list(struct.unpack('<6f', h[256:280]))
for r in range(3): q[3+r] += shift[r]
dims[1:4] = [2*nx, 2*ny, 2*nz]
for i in (1, 2, 3): pix[i] *= 0.5
h[40:56] = struct.pack('<8h', *dims); h[76:108] = struct.pack('<8f', *pix)
h[256:280] = struct.pack('<6f', *q); h[280:328] = struct.pack('<12f', *srow)
out = bytearray()
rowlen = 4 * nx
for k in range(nz):
    sl = bytearray()
    for j in range(ny):
        row = data[(k*ny + j)*rowlen:(k*ny + j + 1)*rowlen]
        r2 = bytearray(2*rowlen)
        for t in range(4):
            r2[t::8] = row[t::4]; r2[4+t::8] = row[t::4]
        sl += r2; sl += r2
    out += sl; out += sl
with gzip.open(dst, 'wb', compresslevel=6) as f:
    f.write(bytes(h) + b[348:off] + bytes(out))
