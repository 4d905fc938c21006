#!/usr/bin/env python3
# make_bomb_png.py OUT.png WIDTH HEIGHT INFLATED: an 8-bit RGB PNG whose one IDAT inflates to
# INFLATED zero bytes (exactly), for tests/grade_test.sh:
# a decompression bomb, or with INFLATED = the declared size a valid black picture. The MiBs are
# one compressed MiB repeated, so a 2 GiB bomb takes a second to make.
import struct, sys, zlib
def chunk(kind, data):
    return (struct.pack('>I', len(data)) + kind + data +
            struct.pack('>I', zlib.crc32(kind + data) & 0xffffffff))
out, w, h, inflated = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4])
mib = 1 << 20
raw = zlib.compressobj(9, zlib.DEFLATED, -15)
block = raw.compress(bytes(mib)) + raw.flush(zlib.Z_FULL_FLUSH)
stream = (b'\x78\xda' + block * (inflated // mib) +
          raw.compress(bytes(inflated % mib)) + raw.flush(zlib.Z_FINISH) +
          struct.pack('>I', ((inflated % 65521) << 16) | 1))  # Adler-32 of zeros
header = struct.pack('>IIBBBBB', w, h, 8, 2, 0, 0, 0)
open(out, 'wb').write(b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', header) + chunk(b'IDAT', stream) +
                      chunk(b'IEND', b''))
