#!/usr/bin/env python3
# SPDX-License-Identifier: Apache-2.0
"""The check on vulkan_triangle's image: the triangle's pixels have the expected colour, where the triangle is.

usage: check_png.py IMAGE.png R G B
The 64x64 image must hold, inside the triangle's bounding box (x 16-47, y 16-47), between 400 and 620 pixels of
colour (R, G, B) within 1/255 per channel (the triangle covers 512; its edges may fall either way), and outside
the box black only. A decoder for the 8-bit RGBA, non-interlaced PNG that libpng's simplified API writes.
"""
import struct
import sys
import zlib


def read_png(path):
    data = open(path, "rb").read()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", "not a PNG"
    at, idat = 8, b""
    while at < len(data):
        length, kind = struct.unpack(">I4s", data[at:at + 8])
        body = data[at + 8:at + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, colour, interlace) == (8, 6, 0), "not 8-bit RGBA, non-interlaced"
        elif kind == b"IDAT":
            idat += body
        at += 12 + length
    raw, stride, rows, previous = zlib.decompress(idat), width * 4, [], bytearray(width * 4)
    for y in range(height):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            left = line[i - 4] if i >= 4 else 0
            up, up_left = previous[i], previous[i - 4] if i >= 4 else 0
            if kind == 1: line[i] = (line[i] + left) & 255
            elif kind == 2: line[i] = (line[i] + up) & 255
            elif kind == 3: line[i] = (line[i] + (left + up) // 2) & 255
            elif kind == 4:
                p = left + up - up_left
                pa, pb, pc = abs(p - left), abs(p - up), abs(p - up_left)
                line[i] = (line[i] + (left if pa <= pb and pa <= pc else up if pb <= pc else up_left)) & 255
        rows.append(line)
        previous = line
    return width, height, rows


def main():
    path, expected = sys.argv[1], [int(v) for v in sys.argv[2:5]]
    width, height, rows = read_png(path)
    assert (width, height) == (64, 64), f"{width}x{height}, expected 64x64"
    coloured, stray = 0, []
    for y in range(height):
        for x in range(width):
            pixel = rows[y][x * 4:x * 4 + 3]
            inside = 16 <= x < 48 and 16 <= y < 48
            if inside and all(abs(p - e) <= 1 for p, e in zip(pixel, expected)):
                coloured += 1
            elif not inside and any(pixel):
                stray.append((x, y, tuple(pixel)))
    print(f"{path}: {coloured} pixels of colour {tuple(expected)} in the triangle's box (limits 400-620); "
          f"{len(stray)} non-black pixels outside it (limit 0)")
    if not 400 <= coloured <= 620 or stray:
        print("FAIL" + (f": first stray pixel {stray[0]}" if stray else ""))
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
