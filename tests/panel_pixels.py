"""panel_pixels.py: the preview window's ray panel on screen against a ray picture.

    python3 tests/panel_pixels.py SHOT X,Y,W,H PICTURE

SHOT is a --window-script shot of the window (a PNG), X,Y,W,H the panel's rectangle in it (the
shot's line says it); PICTURE a --debug-pixel ray picture, whose top-left W x H is the plot
(the views are right of it). Prints "same" when every channel of every pixel is within 1, else
how many pixels differ. Reads 8-bit RGB(A) PNGs with the standard library alone (window_test.sh).
"""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, 'rb').read()
    if data[:8] != b'\x89PNG\r\n\x1a\n':
        sys.exit(path + ': not a PNG')
    at, chunks, header = 8, b'', None
    while at < len(data):
        size, kind = struct.unpack('>I4s', data[at:at + 8])
        body = data[at + 8:at + 8 + size]
        if kind == b'IHDR':
            header = struct.unpack('>IIBBBBB', body)
        elif kind == b'IDAT':
            chunks += body
        at += 12 + size
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in (2, 6) or interlace != 0:
        sys.exit(path + ': not an 8-bit RGB PNG')
    step = 3 if colour == 2 else 4
    raw, rows, previous, at = zlib.decompress(chunks), [], bytearray(width * step), 0
    for _ in range(height):
        kind, row = raw[at], bytearray(raw[at + 1:at + 1 + width * step])
        at += 1 + width * step
        for x in range(len(row)):  # undo the row's filter (PNG specification, section 9)
            a = row[x - step] if x >= step else 0
            b = previous[x]
            c = previous[x - step] if x >= step else 0
            if kind == 1:
                row[x] = (row[x] + a) & 255
            elif kind == 2:
                row[x] = (row[x] + b) & 255
            elif kind == 3:
                row[x] = (row[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                row[x] = (row[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(row[x * step:x * step + 3]) for x in range(width)])
        previous = row
    return width, height, rows


def main():
    shot, rectangle, picture = sys.argv[1:4]
    left, top, width, height = (int(v) for v in rectangle.split(','))
    shot_width, shot_height, shown = read_png(shot)
    picture_width, picture_height, drawn = read_png(picture)
    if left < 0 or top < 0 or left + width > shot_width or top + height > shot_height:
        sys.exit('the panel %s lies outside the %dx%d shot' % (rectangle, shot_width, shot_height))
    if width > picture_width or height > picture_height:
        sys.exit('the panel %dx%d is larger than the %dx%d picture'
                 % (width, height, picture_width, picture_height))
    differ, largest = 0, 0
    for y in range(height):
        for x in range(width):
            d = max(abs(p - q) for p, q in zip(shown[top + y][left + x], drawn[y][x]))
            differ += d > 1
            largest = max(largest, d)
    print('same' if differ == 0 else '%d of %d pixels differ (largest %d)'
          % (differ, width * height, largest))


main()
