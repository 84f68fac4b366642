"""PNG reading and writing for the tools (no Pillow on a bare machine): chunks, zlib, the five row filters in;
8-bit RGB, 8- and 16-bit grey out (unfiltered rows, zlib level 9: the same bytes on every run)."""
import struct
import sys
import zlib

CHANNELS = {0: 1, 2: 3, 4: 2, 6: 4}  # colour type -> channels (palettes are not read)


def decode(path):
    """Returns (width, height, bit depth, colour type, rows): each row the unfiltered bytes of one image row."""
    data = open(path, "rb").read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        sys.exit("%s: not a PNG" % path)
    pos, idat, w, h, depth, colour = 8, b"", 0, 0, 0, 0
    while pos < len(data):
        n = struct.unpack(">I", data[pos:pos + 4])[0]
        tag, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + n]
        pos += 12 + n
        if tag == b"IHDR":
            w, h, depth, colour = struct.unpack(">IIBB", body[:10])
        elif tag == b"IDAT":
            idat += body
    if colour not in CHANNELS or depth not in (8, 16):
        sys.exit("%s: only 8- or 16-bit grey, grey-alpha, RGB or RGBA PNGs" % path)
    bpp = CHANNELS[colour] * depth // 8
    raw, stride, rows, prev, i = zlib.decompress(idat), w * bpp, [], bytearray(w * bpp), 0
    for _ in range(h):
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + stride])
        i += 1 + stride
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if f == 1:
                line[x] = (line[x] + a) & 255
            elif f == 2:
                line[x] = (line[x] + b) & 255
            elif f == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, depth, colour, rows


def read_rgb(path):
    """(width, height, rows): an 8-bit RGB, RGBA, grey or grey-alpha PNG's rows as RGB bytes (width * 3 each)."""
    w, h, depth, colour, raw = decode(path)
    if depth != 8 or colour not in (0, 2, 4, 6):
        sys.exit(path + ": only 8-bit RGB, RGBA, grey or grey-alpha")
    bpp = CHANNELS[colour]
    if colour in (0, 4):  # grey: each value three times
        return w, h, [b"".join(bytes((line[i],)) * 3 for i in range(0, w * bpp, bpp)) for line in raw]
    return w, h, [b"".join(bytes(line[i:i + 3]) for i in range(0, w * bpp, bpp)) for line in raw]


def encode(width, height, depth, colour, rows):
    """PNG bytes of `rows` (bytes each, packed as the depth and colour type say), each row unfiltered."""
    raw = b"".join(b"\x00" + bytes(row) for row in rows)

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, colour, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def write_rgb(path, width, height, rows):
    """Writes 8-bit RGB rows (bytes of width * 3 each) as a PNG."""
    with open(path, "wb") as out:
        out.write(encode(width, height, 8, 2, rows[:height]))


def write_grey8(path, rows):
    """Writes 8-bit grey rows (a list of byte values each) as a PNG."""
    with open(path, "wb") as out:
        out.write(encode(len(rows[0]), len(rows), 8, 0, [bytes(r) for r in rows]))


def write_grey16(path, width, height, pixel):
    """Writes a 16-bit grey PNG whose texel (x, y) is pixel(x, y) in [0, 1] (clamped, rounded to 1/65535)."""
    rows = []
    for y in range(height):
        row = bytearray()
        for x in range(width):
            row += struct.pack(">H", max(0, min(65535, int(round(pixel(x, y) * 65535)))))
        rows.append(bytes(row))
    with open(path, "wb") as out:
        out.write(encode(width, height, 16, 0, rows))


def pictures_from_command_line(doc, least):
    """(OUT, [(width, height, rows), ...]) of a picture tool's command line `OUT IN...` (at least `least` inputs),
    each input read as 8-bit RGB; --help prints `doc`."""
    if len(sys.argv) > 1 and sys.argv[1] in ("-h", "--help"):
        print(doc)
        sys.exit(0)
    if len(sys.argv) < 2 + least:
        sys.exit(doc)
    return sys.argv[1], [read_rgb(p) for p in sys.argv[2:]]
