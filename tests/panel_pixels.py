"""panel_pixels.py: the preview window's ray panel on screen against a ray picture.

    python3 tests/panel_pixels.py SHOT X,Y,W,H PICTURE

SHOT is a --window-script shot of the window (a PNG), X,Y,W,H the panel's rectangle in it (the
shot's line says it); PICTURE a --debug-pixel ray picture, whose top-left W x H is the plot
(the views are right of it). Prints "same" when every channel of every pixel is within 1, else
how many pixels differ. Reads 8-bit RGB(A) PNGs with the standard library alone (window_test.sh).
Only the rows and columns up to the rectangle's far edges are unfiltered: a pixel's filter
reads the pixels left of it and above it, never right or below.
"""
import struct
import sys
import zlib


def read_png(path, rows_needed, columns_needed):
    """(width, height, step, rows): the first rows_needed rows (at most the height), each a
    bytearray of its first columns_needed pixels (step bytes a pixel: 3 RGB, 4 RGBA)."""
    data = open(path, 'rb').read()
    if data[:8] != b'\x89PNG\r\n\x1a\n':
        sys.exit(path + ': not a PNG')
    at, chunks, header = 8, [], None
    while at < len(data):
        size, kind = struct.unpack('>I4s', data[at:at + 8])
        body = data[at + 8:at + 8 + size]
        if kind == b'IHDR':
            header = struct.unpack('>IIBBBBB', body)
        elif kind == b'IDAT':
            chunks.append(body)
        at += 12 + size
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in (2, 6) or interlace != 0:
        sys.exit(path + ': not an 8-bit RGB PNG')
    step = 3 if colour == 2 else 4
    stride = width * step
    used = min(width, columns_needed) * step  # the bytes of a row that are unfiltered
    raw, rows, previous = zlib.decompress(b''.join(chunks)), [], bytearray(used)
    for y in range(min(height, rows_needed)):
        at = y * (1 + stride)
        kind, row = raw[at], bytearray(raw[at + 1:at + 1 + used])
        # Undo the row's filter (PNG specification, section 9), one loop per filter type.
        if kind == 1:  # Sub
            for x in range(step, used):
                row[x] = (row[x] + row[x - step]) & 255
        elif kind == 2:  # Up
            row = bytearray((r + b) & 255 for r, b in zip(row, previous))
        elif kind == 3:  # Average
            for x in range(used):
                a = row[x - step] if x >= step else 0
                row[x] = (row[x] + (a + previous[x]) // 2) & 255
        elif kind == 4:  # Paeth
            for x in range(used):
                if x >= step:
                    a, c = row[x - step], previous[x - step]
                else:
                    a = c = 0
                b = previous[x]
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                row[x] = (row[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(row)
        previous = row
    return width, height, step, rows


def main():
    shot, rectangle, picture = sys.argv[1:4]
    left, top, width, height = (int(v) for v in rectangle.split(','))
    shot_width, shot_height, shot_step, shown = read_png(shot, top + height, left + width)
    picture_width, picture_height, picture_step, drawn = read_png(picture, height, width)
    if left < 0 or top < 0 or left + width > shot_width or top + height > shot_height:
        sys.exit('the panel %s lies outside the %dx%d shot' % (rectangle, shot_width, shot_height))
    if width > picture_width or height > picture_height:
        sys.exit('the panel %dx%d is larger than the %dx%d picture'
                 % (width, height, picture_width, picture_height))
    differ, largest = 0, 0
    for y in range(height):
        shown_row, drawn_row = shown[top + y], drawn[y]
        # Channel by channel (every step-th byte): a row whose R, G and B are the same bytes
        # has no pixel more than 1 off; only a row that is not is compared pixel by pixel.
        planes = [(shown_row[left * shot_step + channel::shot_step][:width],
                   drawn_row[channel::picture_step][:width]) for channel in range(3)]
        if all(a == b for a, b in planes):
            continue
        for x in range(width):
            d = max(abs(a[x] - b[x]) for a, b in planes)
            differ += d > 1
            largest = max(largest, d)
    print('same' if differ == 0 else '%d of %d pixels differ (largest %d)'
          % (differ, width * height, largest))


main()
