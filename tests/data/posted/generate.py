#!/usr/bin/env python3
"""Writes the posted-program corpus (tests/data/posted/<style>/program.*): ISO G-code as CAM
posts and controls write it, one program per post style, written for vmsim's tests by hand
(geometry generated here, format as each post writes it). Not run by CI: the programs are
checked in; run it again only to change the corpus (python3 generate.py from this folder).

Each program machines a part in a stock whose top is the work zero Z0 (X0 Y0 at the stock
centre unless said), so that every program needs the set-up of its part file (work offset,
tool table) to run: that is what the corpus tests.
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def fmt(value, decimals, style="fanuc"):
    """A number as posts write it. fanuc: trailing point on integers ("10."), no trailing zeros;
    fixed: always `decimals` digits (FreeCAD, PowerMill); lead: like fanuc but no leading zero
    ("X.5", Mastercam)."""
    v = round(value, decimals)
    if decimals == 0:
        return f"{int(v)}" + ("" if style == "fixed" else ".")
    if v == 0:
        v = 0.0  # no "-0."
    if style == "fixed":
        return f"{v:.{decimals}f}"
    text = f"{v:.{decimals}f}".rstrip("0")
    if style == "lead":
        if text.startswith("0.") and len(text) > 2:
            text = text[1:]
        elif text.startswith("-0.") and len(text) > 3:
            text = "-" + text[2:]
    return text


class Writer:
    def __init__(self, decimals=3, style="fanuc", numbered=False, number_step=5,
                 number_width=0, g_zero=False):
        self.lines = []
        self.decimals = decimals
        self.style = style
        self.numbered = numbered
        self.number = 0
        self.number_step = number_step
        self.number_width = number_width
        self.g_zero = g_zero  # G00 G01 G02 G03 (Haas, NX)
        self.modal = {}
        self.motion = None

    def raw(self, text):
        if self.numbered and text and not text.startswith(("%", "(", "O")):
            self.number += self.number_step
            n = str(self.number).zfill(self.number_width)
            text = f"N{n} {text}"
        self.lines.append(text)

    def g(self, code):
        if self.g_zero and code in (0, 1, 2, 3):
            return f"G0{code}"
        return f"G{code}"

    def num(self, v):
        return fmt(v, self.decimals, self.style)

    def move(self, code, x=None, y=None, z=None, f=None, extra="", force=False, **arc):
        words = []
        if code != self.motion or force:
            words.append(self.g(code))
            self.motion = code
        for letter, v in (("X", x), ("Y", y), ("Z", z)):
            if v is None:
                continue
            text = self.num(v)
            if code in (2, 3) or self.modal.get(letter) != text or force:
                words.append(letter + text)
                self.modal[letter] = text
        for letter in ("I", "J", "K", "R"):
            if letter in arc:
                words.append(letter + self.num(arc[letter]))
        if f is not None:
            ftext = fmt(f, 0 if f >= 100 else 1, "fanuc" if self.style != "fixed" else "fixed")
            if self.modal.get("F") != ftext or code in (2, 3) and False:
                words.append("F" + ftext)
                self.modal["F"] = ftext
        if extra:
            words.append(extra)
        if len(words) > (0 if force else 0) and any(w[0] in "XYZIJKR" for w in words):
            self.raw(" ".join(words))

    def forget(self):
        """After a tool change, G28, a cycle: posts write every word again."""
        self.modal = {}
        self.motion = None

    def write(self, path, ending="\n"):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w", newline="") as f:
            f.write(ending.join(self.lines) + ending)


# ---- geometry -------------------------------------------------------------------------------

def rounded_rect(w, h, r, cx=0.0, cy=0.0):
    """A closed rounded rectangle, climb (clockwise seen from +Z) from the middle of the left
    side: a list of ("line", x, y) and ("arc", x, y, i, j, cw) pieces."""
    x0, x1, y0, y1 = cx - w / 2, cx + w / 2, cy - h / 2, cy + h / 2
    p = [("start", x0, cy),
         ("line", x0, y1 - r), ("arc", x0 + r, y1, r, 0.0, True),
         ("line", x1 - r, y1), ("arc", x1, y1 - r, 0.0, -r, True),
         ("line", x1, y0 + r), ("arc", x1 - r, y0, -r, 0.0, True),
         ("line", x0 + r, y0), ("arc", x0, y0 + r, 0.0, r, True),
         ("line", x0, cy)]
    return p


def emit_contour(wr, pieces, feed, z=None):
    for piece in pieces[1:]:
        if piece[0] == "line":
            wr.move(1, piece[1], piece[2], z, feed)
        else:
            _, x, y, i, j, cw = piece
            wr.move(2 if cw else 3, x, y, None, feed, I=i, J=j)


def pocket(wr, w, h, r, depth, step_down, stepover, tool_d, feed, plunge_feed, clear_z,
           helix=True):
    """Offset-contour pocket, climb, helical ramp entry (half circles), as adaptive/2D pocket
    posts write it: 3-decimal arcs whose centres are rounded."""
    levels = max(1, int(math.ceil(depth / step_down - 1e-9)))
    for level in range(1, levels + 1):
        z = -min(depth, level * step_down)
        # Rings from the inside out.
        rings = []
        inset = tool_d / 2
        max_inset = min(w, h) / 2 - 0.2
        k = 0
        while True:
            off = inset + k * stepover
            if off > max_inset:
                break
            k += 1
        for m in range(k - 1, -1, -1):
            off = inset + m * stepover
            rr = max(0.5, r - off + tool_d / 2) if r > off - tool_d / 2 else 0.5
            rings.append((w - 2 * off, h - 2 * off, min(rr, (min(w, h) - 2 * off) / 2 - 1e-3)))
        first = rounded_rect(*rings[0])
        sx, sy = first[0][1], first[0][2]
        wr.move(0, sx + 1.0, sy, None)
        wr.move(0, None, None, clear_z)
        wr.move(1, None, None, z + step_down + 0.5, plunge_feed)
        if helix:
            # Helix down around (sx, sy) radius 1 in half turns of 0.5 mm.
            zc = z + step_down + 0.5
            turn = 0
            while zc > z + 1e-9:
                zc = max(z, zc - 0.5)
                if turn % 2 == 0:
                    wr.move(2, sx - 1.0, sy, zc, plunge_feed, I=-1.0, J=0.0)
                else:
                    wr.move(2, sx + 1.0, sy, zc, plunge_feed, I=1.0, J=0.0)
                turn += 1
            if turn % 2 == 1:
                wr.move(2, sx + 1.0, sy, z, plunge_feed, I=1.0, J=0.0)
        else:
            wr.move(1, None, None, z, plunge_feed)
        wr.move(1, sx, sy, z, feed)
        for ring in rings:
            pieces = rounded_rect(*ring)
            wr.move(1, pieces[0][1], pieces[0][2], z, feed)
            emit_contour(wr, pieces, feed)
        wr.move(0, None, None, clear_z)


def bump(x, y, cx=0.0, cy=0.0, height=8.0, radius=30.0):
    """A smooth bump: the surface a 3-D finishing pass follows."""
    d2 = ((x - cx) ** 2 + (y - cy) ** 2) / radius ** 2
    return -10.0 + height * math.exp(-2.0 * d2)


def raster(wr, x0, x1, y0, y1, step_y, step_x, feed, clear_z, surface, ball_r=0.0, zigzag=True,
           lift=None):
    """Parallel finishing along X, tip on the surface + nothing (ball tip on the surface: the
    CAM has offset it; here the surface is the tip surface)."""
    y = y0
    row = 0
    first = True
    while y <= y1 + 1e-9:
        xs = [x0 + k * step_x for k in range(int(round((x1 - x0) / step_x)) + 1)]
        if zigzag and row % 2 == 1:
            xs.reverse()
        if first:
            wr.move(0, xs[0], y, None)
            wr.move(0, None, None, clear_z)
            wr.move(1, None, None, surface(xs[0], y) + 2.0, feed / 4)
            first = False
        elif lift is not None or not zigzag:
            wr.move(0, None, None, clear_z if lift is None else lift)
            wr.move(0, xs[0], y, None)
            wr.move(1, None, None, surface(xs[0], y) + 1.0, feed / 4)
        for x in xs:
            wr.move(1, x, y, surface(x, y), feed)
        y += step_y
        row += 1
    wr.move(0, None, None, clear_z)


HOLES = [(-30.0, -25.0), (0.0, -25.0), (30.0, -25.0), (30.0, 25.0), (0.0, 25.0), (-30.0, 25.0)]


# ---- the programs -----------------------------------------------------------------------------

def fusion360(inch):
    """Autodesk Fusion 360, generic Fanuc post: O number and tool list in comments, the safe
    preamble with G49, G28 G91 Z0. retracts, G54 after each tool change, G43 Z H on the first
    Z move, 3 decimals in mm / 4 in inch (arc centres rounded like that), M1 between
    operations, helical ramps, G83 peck drilling, a contour with arc lead-in and lead-out."""
    s = 1 / 25.4 if inch else 1.0
    wr = Writer(decimals=4 if inch else 3)
    wr.raw("%")
    wr.raw("O1001 (BRACKET)")
    wr.raw("(T1 D=%s CR=0. - ZMIN=%s - FLAT END MILL)" % (wr.num(10 * s), wr.num(-8 * s)))
    wr.raw("(T2 D=%s CR=0. - ZMIN=%s - FLAT END MILL)" % (wr.num(6 * s), wr.num(-12 * s)))
    wr.raw("G90 G94 G17 G49 G40 G80")
    wr.raw("G20" if inch else "G21")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("")
    wr.raw("(2D POCKET1)")
    wr.raw("T1 M6")
    wr.raw("S8000 M3")
    wr.raw("G54")
    wr.raw("M8")
    wr.forget()
    feed, plunge = 1200 * s, 300 * s
    # The pocket, in program units.
    w, h, r, depth = 50 * s, 40 * s, 6 * s, 8 * s
    first = rounded_rect(w - 2 * (5 * s), h - 2 * (5 * s), 1 * s)
    wr.move(0, first[0][1] + 1 * s, first[0][2])
    wr.raw("G43 Z%s H1" % wr.num(15 * s))
    wr.modal["Z"] = wr.num(15 * s)
    wr.move(0, None, None, 5 * s)
    pocket(wr, w, h, r, depth, 2 * s, 1.5 * s, 10 * s, feed, plunge, 5 * s)
    wr.move(0, None, None, 15 * s)
    wr.raw("M9")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("")
    wr.raw("(DRILL1)")
    wr.raw("M1")
    wr.raw("T2 M6")
    wr.raw("S3000 M3")
    wr.raw("G54")
    wr.raw("M8")
    wr.forget()
    x, y = HOLES[0]
    wr.move(0, x * s, y * s)
    wr.raw("G43 Z%s H2" % wr.num(15 * s))
    wr.raw("G0 Z%s" % wr.num(5 * s))
    wr.raw("G98 G83 X%s Y%s Z%s R%s Q%s F%s" % (wr.num(x * s), wr.num(y * s), wr.num(-12 * s),
                                              wr.num(5 * s), wr.num(3 * s), fmt(200 * s, 1)))
    px, py = x, y
    for x, y in HOLES[1:]:
        words = []
        if x != px:
            words.append("X" + wr.num(x * s))
        if y != py:
            words.append("Y" + wr.num(y * s))
        wr.raw(" ".join(words))
        px, py = x, y
    wr.raw("G80")
    wr.raw("Z%s" % wr.num(15 * s))
    wr.raw("M9")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("")
    wr.raw("(2D CONTOUR1)")
    wr.raw("M1")
    wr.raw("T1 M6")
    wr.raw("S8000 M3")
    wr.raw("G54")
    wr.raw("M8")
    wr.forget()
    # Outside profile 90 x 70 R8 (part edge), tool centre 5 mm outside, two depths.
    pieces = rounded_rect(100 * s, 80 * s, 13 * s)
    sx, sy = pieces[0][1], pieces[0][2]
    lead = 5 * s
    wr.move(0, sx - 2 * lead, sy - lead)
    wr.raw("G43 Z%s H1" % wr.num(15 * s))
    wr.modal["Z"] = wr.num(15 * s)
    for depth in (2.5 * s, 5 * s):
        wr.move(0, None, None, 5 * s)
        wr.move(1, None, None, -depth, plunge)
        wr.move(1, sx - lead, sy - lead, None, feed)
        wr.move(3, sx, sy, None, feed, I=0.0, J=lead)  # arc lead-in, tangent to the profile
        emit_contour(wr, pieces, feed)
        wr.move(3, sx - lead, sy + lead, None, feed, I=-lead, J=0.0)  # lead-out
        wr.move(1, sx - 2 * lead, sy + lead, None, feed)
        wr.move(0, None, None, 15 * s)
        wr.move(0, sx - 2 * lead, sy - lead)
    wr.raw("M9")
    wr.raw("M5")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("G28 G91 X0. Y0.")
    wr.raw("G90")
    wr.raw("M30")
    wr.raw("%")
    name = "fusion360_inch" if inch else "fusion360_mm"
    wr.write(os.path.join(HERE, name, "program.nc"))


def mastercam():
    """Mastercam, generic Fanuc 3X mill post: leading-point numbers (X.5), R-format arcs,
    A0. on the positioning lines of a 4/5-axis machine, G43 H Z on one line, G99 G81 drilling,
    G91 G28 Z0. and G28 X0. Y0. A0. at the end."""
    wr = Writer(decimals=4, style="lead")
    wr.raw("%")
    wr.raw("O0002(COVER PLATE)")
    wr.raw("(DATE=DD-MM-YY - 02-12-26 TIME=HH:MM - 15:30)")
    wr.raw("(MCX FILE - C:\\USERS\\CAM\\COVER.MCAM)")
    wr.raw("(NC FILE - C:\\USERS\\CAM\\COVER.NC)")
    wr.raw("(MATERIAL - ALUMINUM MM - 6061)")
    wr.raw("( T1 |  10. FLAT ENDMILL | H1 )")
    wr.raw("( T2 |  6. FLAT ENDMILL | H2 )")
    wr.raw("G21")
    wr.raw("G0 G17 G40 G49 G80 G90")
    wr.raw("T1 M6")
    wr.forget()
    pieces = rounded_rect(40, 30, 5)
    sx, sy = pieces[0][1], pieces[0][2]
    wr.raw("G0 G90 G54 X%s Y%s A0. S8000 M3" % (wr.num(sx), wr.num(sy)))
    wr.modal.update({"X": wr.num(sx), "Y": wr.num(sy)})
    wr.motion = 0
    wr.raw("G43 H1 Z25.")
    wr.modal["Z"] = "25."
    wr.move(0, None, None, 5.0)
    for k in range(1, 4):
        z = -1.5 * k
        wr.move(1, None, None, z, 250)
        for piece in pieces[1:]:
            if piece[0] == "line":
                wr.move(1, piece[1], piece[2], None, 1000)
            else:
                _, x, y, i, j, cw = piece
                rad = math.hypot(i, j)
                wr.move(2 if cw else 3, x, y, None, 1000, R=rad)
    # A full circle: I J (R cannot program one).
    wr.move(1, 8.0, 0.0, None, 1000)
    wr.move(2, 8.0, 0.0, None, 1000, I=-8.0, J=0.0)
    wr.move(0, None, None, 25.0)
    wr.raw("M5")
    wr.raw("G91 G28 Z0.")
    wr.raw("M01")
    wr.raw("T2 M6")
    wr.forget()
    x, y = HOLES[0]
    wr.raw("G0 G90 G54 X%s Y%s A0. S3000 M3" % (wr.num(x), wr.num(y)))
    wr.raw("G43 H2 Z25.")
    wr.raw("G99 G81 Z-10. R3. F150.")
    for x, y in HOLES[1:]:
        wr.raw("X%s Y%s" % (wr.num(x), wr.num(y)))
    wr.raw("G80")
    wr.raw("M5")
    wr.raw("G91 G28 Z0.")
    wr.raw("G28 X0. Y0. A0.")
    wr.raw("M30")
    wr.raw("%")
    wr.write(os.path.join(HERE, "mastercam", "program.nc"))


def powermill():
    """Autodesk PowerMill, Fanuc post: N numbers every line, fixed 3 decimals, modal G1 lines
    with only the words that change, a 3-D raster finish of a smooth bump with a ball mill (a
    long program), G91 G28 Z0.0 at both ends."""
    wr = Writer(decimals=3, style="fixed", numbered=True, number_step=10)
    wr.raw("%")
    wr.raw("O0003")
    wr.raw("(BUMP FINISH - BALL 6)")
    wr.raw("G91 G28 Z0.0")
    wr.raw("G40 G17 G80 G49")
    wr.raw("G21 G90")
    wr.raw("T3 M6")
    wr.raw("G90 G54")
    wr.forget()
    surface = lambda x, y: bump(x, y, height=8.0, radius=28.0) + 8.0 - 8.0
    wr.raw("G0 X-40.000 Y-30.000")
    wr.modal.update({"X": "-40.000", "Y": "-30.000"})
    wr.motion = 0
    wr.raw("G43 Z20.000 H3")
    wr.modal["Z"] = "20.000"
    wr.raw("S12000 M3")
    raster(wr, -40.0, 40.0, -30.0, 30.0, 0.6, 0.8, 2500.0, 20.0, surface)
    wr.raw("M5")
    wr.raw("G91 G28 Z0.0")
    wr.raw("G90")
    wr.raw("M30")
    wr.raw("%")
    wr.write(os.path.join(HERE, "powermill", "program.tap"))


def nx():
    """Siemens NX, Post Builder Fanuc 30i: four-digit N numbers, G00/G01 with a leading zero,
    T01 M06, G43 Z H01, AI contour / high-precision mode G05.1 Q1 around the cutting moves, a
    zig-zag face mill and a finishing contour with a vertical (G19) arc lead-in."""
    wr = Writer(decimals=3, numbered=True, number_step=10, number_width=4, g_zero=True)
    wr.raw("%")
    wr.raw("O0004")
    wr.raw("G40 G17 G90 G21")
    wr.raw("G91 G28 Z0.0")
    wr.raw("T01 M06")
    wr.raw("G00 G90 G54 X-55. Y-38. S6000 M03")
    wr.forget()
    wr.modal.update({"X": "-55.", "Y": "-38."})
    wr.motion = 0
    wr.raw("G43 Z30. H01")
    wr.modal["Z"] = "30."
    wr.raw("G05.1 Q1")
    wr.move(0, None, None, 3.0)
    wr.move(1, None, None, -1.0, 300)
    y = -38.0
    row = 0
    while y <= 38.0 + 1e-9:
        x_end = 55.0 if row % 2 == 0 else -55.0
        wr.move(1, x_end, y, None, 1500)
        y += 7.0
        if y <= 38.0 + 1e-9:
            wr.move(1, None, y, None, 1500)
        row += 1
    wr.move(0, None, None, 30.0)
    # Finishing contour at Z-4, entered by a quarter arc in the YZ plane (G19).
    pieces = rounded_rect(84, 64, 10)
    sx, sy = pieces[0][1], pieces[0][2]
    wr.move(0, sx, sy - 5.0)
    wr.move(0, None, None, 3.0)
    wr.move(1, None, None, 1.0, 300)
    wr.raw("G19")
    wr.move(3, sx, sy, -4.0, 800, J=5.0, K=0.0, force=True)
    wr.raw("G17")
    wr.forget()
    wr.move(1, sx, sy, -4.0, 800, force=True)
    emit_contour(wr, pieces, 800)
    wr.move(0, None, None, 30.0)
    wr.raw("G05.1 Q0")
    wr.raw("M05")
    wr.raw("G91 G28 Z0.0")
    wr.raw("G90")
    wr.raw("M30")
    wr.raw("%")
    wr.write(os.path.join(HERE, "nx", "program.ptp"))


def freecad():
    """FreeCAD Path, linuxcnc_post: comments around every operation, the preamble
    G17 G54 G40 G49 G80 G90 / G21, `M6 T1` then `G43 H1` alone, fixed 3 decimals on every
    word, F on every feed move, a LinuxCNC path blending mode G64 P in a user preamble, a
    profile with helical arcs (G2 with Z), M2 at the end."""
    wr = Writer(decimals=3, style="fixed")
    wr.raw("(Exported by FreeCAD)")
    wr.raw("(Post Processor: linuxcnc_post)")
    wr.raw("(Output Time:2026-12-02 15:30:00.000000)")
    wr.raw("(begin preamble)")
    wr.raw("G17 G54 G40 G49 G80 G90")
    wr.raw("G21")
    wr.raw("G64 P0.010")
    wr.raw("(begin operation: TC: Endmill)")
    wr.raw("(machine units: mm/min)")
    wr.raw("M5")
    wr.raw("M6 T1")
    wr.raw("G43 H1")
    wr.raw("M3 S6000.000")
    wr.raw("(finish operation: TC: Endmill)")
    wr.raw("(begin operation: Fixture)")
    wr.raw("(machine units: mm/min)")
    wr.raw("G54")
    wr.raw("(finish operation: Fixture)")
    wr.raw("(begin operation: Profile)")
    wr.raw("(machine units: mm/min)")
    r = 25.0
    wr.raw("G0 Z15.000")
    wr.raw("G0 X%s Y0.000" % wr.num(r))
    wr.raw("G0 Z5.000")
    wr.raw("G1 X%s Y0.000 Z0.000 F300.000" % wr.num(r))
    # Helix down in half turns of 0.75 mm to Z-6, a finishing turn, each block with F.
    z = 0.0
    k = 0
    while z > -6.0 + 1e-9:
        z = max(-6.0, z - 0.75)
        if k % 2 == 0:
            wr.raw("G2 X%s Y0.000 Z%s I%s J0.000 F600.000" % (wr.num(-r), wr.num(z), wr.num(-r)))
        else:
            wr.raw("G2 X%s Y0.000 Z%s I%s J0.000 F600.000" % (wr.num(r), wr.num(z), wr.num(r)))
        k += 1
    if k % 2 == 1:
        wr.raw("G2 X%s Y0.000 Z-6.000 I%s J0.000 F600.000" % (wr.num(r), wr.num(-r)))
    wr.raw("G2 X%s Y0.000 Z-6.000 I%s J0.000 F600.000" % (wr.num(-r), wr.num(-r)))
    wr.raw("G2 X%s Y0.000 Z-6.000 I%s J0.000 F600.000" % (wr.num(r), wr.num(r)))
    wr.raw("G0 Z15.000")
    wr.raw("(finish operation: Profile)")
    # A pocket of straight zig-zag lines, every word written, F on every G1.
    wr.raw("(begin operation: Pocket)")
    wr.raw("(machine units: mm/min)")
    wr.raw("G0 Z15.000")
    wr.raw("G0 X-12.000 Y-12.000")
    wr.raw("G0 Z5.000")
    wr.raw("G1 X-12.000 Y-12.000 Z-3.000 F300.000")
    y = -12.0
    row = 0
    while y <= 12.0 + 1e-9:
        x_end = 12.0 if row % 2 == 0 else -12.0
        wr.raw("G1 X%s Y%s Z-3.000 F900.000" % (wr.num(x_end), wr.num(y)))
        if y + 2.0 <= 12.0 + 1e-9:
            wr.raw("G1 X%s Y%s Z-3.000 F900.000" % (wr.num(x_end), wr.num(y + 2.0)))
        y += 2.0
        row += 1
    wr.raw("G0 Z15.000")
    wr.raw("(finish operation: Pocket)")
    wr.raw("(begin postamble)")
    wr.raw("M05")
    wr.raw("G17 G54 G90 G80 G40")
    wr.raw("M2")
    wr.write(os.path.join(HERE, "freecad_linuxcnc", "program.ngc"))


def haas():
    """Haas NGC as Fusion's Haas post writes it: G00/G01 with leading zeros, T1 M06, G187
    P-smoothing with E tolerance, G43 H01 Z, G53 G00 Z0. machine-coordinate retracts, a G73
    high-speed peck and a pocket with a bull-nose mill."""
    wr = Writer(decimals=4, g_zero=True)
    wr.raw("%")
    wr.raw("O01005 (HAAS VF2 PLATE)")
    wr.raw("(T1 D=12. CR=1. - ZMIN=-6. - BULL NOSE END MILL)")
    wr.raw("(T2 D=6. CR=0. - ZMIN=-9. - FLAT END MILL)")
    wr.raw("G00 G17 G40 G49 G80 G90")
    wr.raw("G21")
    wr.raw("T1 M06")
    wr.raw("S7000 M03")
    wr.forget()
    first = rounded_rect(50 - 12, 40 - 12, 1)
    wr.raw("G00 G90 G54 X%s Y%s" % (wr.num(first[0][1] + 1), wr.num(first[0][2])))
    wr.modal.update({"X": wr.num(first[0][1] + 1), "Y": wr.num(first[0][2])})
    wr.motion = 0
    wr.raw("G43 H01 Z15.")
    wr.modal["Z"] = "15."
    wr.raw("M08")
    wr.raw("G187 P2 E0.05")
    pocket(wr, 50, 40, 6, 6, 2, 2.0, 12, 1500, 400, 5)
    wr.raw("G187")
    wr.raw("M09")
    wr.raw("G53 G00 Z0.")
    wr.raw("M01")
    wr.raw("T2 M06")
    wr.raw("S4000 M03")
    wr.forget()
    x, y = HOLES[0]
    wr.raw("G00 G90 G54 X%s Y%s" % (wr.num(x), wr.num(y)))
    wr.raw("G43 H02 Z15.")
    wr.raw("M08")
    wr.raw("G98 G73 Z-9. R3. Q1.5 F250.")
    for x, y in HOLES[1:]:
        wr.raw("X%s Y%s" % (wr.num(x), wr.num(y)))
    wr.raw("G80")
    wr.raw("M09")
    wr.raw("G53 G00 Z0.")
    wr.raw("M05")
    wr.raw("G53 G00 X0. Y0.")
    wr.raw("M30")
    wr.raw("%")
    wr.write(os.path.join(HERE, "haas", "program.nc"))


LINUXCNC_MACROS = """%
(Hole pattern and an engraved circle, hand-written for LinuxCNC with O-word subroutines,)
(named parameters and expressions)
G21 G90 G17 G40 G49 G80
G64 P0.01
G54
#<depth> = -2.0
#<radius> = 20
#<_feed> = 600
o100 sub
  (spot one hole: #1 x, #2 y, #3 depth)
  G0 X#1 Y#2
  G0 Z2
  G1 Z#3 F[#<_feed> / 3]
  G0 Z5
o100 endsub
T1 M6
G43 H1
G0 Z10
#1 = 0
o101 while [#1 LT 8]
  o100 call [#<radius> * COS[#1 * 45]] [#<radius> * SIN[#1 * 45]] [#<depth>]
  #1 = [#1 + 1]
o101 endwhile
(an engraved circle of G1 points, 2 deg apart, then a square if the radius allows)
#2 = 0
#3 = [#<radius> + 5]
G0 X#3 Y0
G1 Z-1 F200
o102 while [#2 LE 360]
  G1 X[#3 * COS[#2]] Y[#3 * SIN[#2]] F#<_feed>
  #2 = [#2 + 2]
o102 endwhile
G0 Z10
o103 if [#3 GT 20]
  G0 X-30 Y-30
  G1 Z-1 F200
  G1 X30 F#<_feed>
  Y30
  X-30
  Y-30
o103 else
  G0 X0 Y0
o103 endif
G0 Z10
M2
%
"""

FANUC_MACRO_B = """%
O2000 (HOLE GRID AND TWO POCKETS - CUSTOM MACRO B)
G21 G90 G17 G40 G49 G80
T1 M6
G54 G0 X0 Y0 S4000 M3
G43 H1 Z20.
#100=4 (COLUMNS)
#101=3 (ROWS)
#102=20. (PITCH)
#103=0
WHILE [#103 LT #101] DO1
#104=0
WHILE [#104 LT #100] DO2
#105=-30.+#104*#102
#106=-20.+#103*#102
G98 G81 X#105 Y#106 Z-6. R2. F150.
#104=#104+1
END2
#103=#103+1
END1
G80
G0 Z20.
IF [#100 NE 4] GOTO 100
(POCKETS BY SUBPROGRAM AT TWO LOCAL OFFSETS)
G52 X-25. Y0.
M98 P2100
G52 X25. Y0.
M98 P2100
G52 X0 Y0
N100 G91 G28 Z0.
G90
M30
O2100 (SQUARE POCKET 10 X 10)
G0 X0 Y0
Z2.
G1 Z-3. F100.
G1 X5. F400.
Y5.
X-5.
Y-5.
X5.
Y0
X0
G0 Z20.
M99
%
"""


def five_axis_tcp():
    """A 5-axis dome finish for an XYZ-AC table-table machine on a Fanuc 30i with TCP
    (G43.4), as a 5-axis post writes it: G43.4 H on the first move, X Y Z A C on every point,
    the table re-oriented at the safe height before the approach (rotary axes only), G49
    before the G28 retract, 3 decimals."""
    wr = Writer(decimals=3)
    wr.raw("%")
    wr.raw("O3000 (DOME 5X FINISH)")
    wr.raw("(T5 D=10. CR=5. - BALL END MILL)")
    wr.raw("G90 G94 G17 G49 G40 G80")
    wr.raw("G21")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("T5 M6")
    wr.raw("S12000 M3")
    wr.raw("G54")
    wr.raw("G0 A0. C0.")
    radius = 25.0  # dome on the table, centre at the work zero, tip on the sphere

    def pose(polar_deg, azimuth_deg):
        p, a = math.radians(polar_deg), math.radians(azimuth_deg)
        n = (math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p))
        tip = tuple(radius * c for c in n)
        # Tool axis in W of an A (about X) - C (about Z) table: (sin A sin C, sin A cos C, cos A);
        # the branch with A <= 0 (this machine's A travel is -120..30 deg).
        a_deg = -polar_deg
        c_deg = math.degrees(math.atan2(-n[0], -n[1]))
        return tip, a_deg, c_deg, n

    tip, a_deg, c_deg, n = pose(15.0, 0.0)
    wr.raw("G43.4 H5")
    # Re-orientation at the safe height: the tip stays, the table turns.
    safe = tuple(t + 40.0 * c for t, c in zip(tip, n))
    wr.raw("G0 X%s Y%s Z%s" % (wr.num(safe[0]), wr.num(safe[1]), wr.num(40.0 + radius)))
    wr.raw("G0 A%s C%s" % (wr.num(a_deg), wr.num(c_deg)))
    wr.raw("G0 X%s Y%s Z%s" % tuple(wr.num(v) for v in safe))
    approach = tuple(t + 3.0 * c for t, c in zip(tip, n))
    wr.raw("G1 X%s Y%s Z%s F500." % tuple(wr.num(v) for v in approach))
    wr.raw("X%s Y%s Z%s F2000." % tuple(wr.num(v) for v in tip))
    # A spiral from 15 to 55 deg polar in 8 turns, a point every 2 deg of azimuth.
    steps = 8 * 180
    previous_c = c_deg
    for k in range(1, steps + 1):
        azimuth = 2.0 * k
        polar = 15.0 + 40.0 * k / steps
        tip, a_deg, c_deg, n = pose(polar, azimuth)
        # Keep C continuous (the post unwinds it, the table turns 8 times).
        while c_deg - previous_c > 180.0:
            c_deg -= 360.0
        while c_deg - previous_c < -180.0:
            c_deg += 360.0
        previous_c = c_deg
        wr.raw("X%s Y%s Z%s A%s C%s" % (wr.num(tip[0]), wr.num(tip[1]), wr.num(tip[2]),
                                         wr.num(a_deg), wr.num(c_deg)))
    retract = tuple(t + 40.0 * c for t, c in zip(tip, n))
    wr.raw("G0 X%s Y%s Z%s" % tuple(wr.num(v) for v in retract))
    wr.raw("G49")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("G0 A0. C0.")
    wr.raw("M5")
    wr.raw("M30")
    wr.raw("%")
    wr.write(os.path.join(HERE, "five_axis_tcp", "program.nc"))


def fanuc_cutter_comp():
    """A Fanuc contour finishing pass programmed on the part's contour with cutter radius
    compensation (G41 D1: the control offsets by the tool table's radius): a 60 x 40 boss with
    6 mm corners, climb (clockwise, tool on the left), a line and a tangent arc lead-in and an arc
    lead-out, G40 on the exit line, two depths."""
    wr = Writer(decimals=3)
    wr.raw("%")
    wr.raw("O1019 (BOSS FINISH - CUTTER COMP)")
    wr.raw("(T1 D=10. FLAT END MILL - D1 RADIUS 5. IN THE OFFSET TABLE)")
    wr.raw("G90 G94 G17 G49 G40 G80")
    wr.raw("G21")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("T1 M6")
    wr.raw("S8000 M3")
    wr.raw("G54 G0 X-60. Y-10.")
    wr.raw("G43 Z15. H1")
    wr.raw("M8")
    a, b, rc, lead = 30.0, 20.0, 6.0, 10.0
    n = wr.num
    for z in (-2.5, -5.0):
        wr.raw("(PASS Z%s)" % n(z))
        wr.raw("G0 X-60. Y-10.")
        wr.raw("Z2.")
        wr.raw("G1 Z%s F300." % n(z))
        wr.raw("G41 D1 X%s Y%s F800." % (n(-a - lead), n(-lead)))
        wr.raw("G3 X%s Y0. I0. J%s" % (n(-a), n(lead)))
        wr.raw("G1 Y%s" % n(b - rc))
        wr.raw("G2 X%s Y%s I%s J0." % (n(-a + rc), n(b), n(rc)))
        wr.raw("G1 X%s" % n(a - rc))
        wr.raw("G2 X%s Y%s I0. J%s" % (n(a), n(b - rc), n(-rc)))
        wr.raw("G1 Y%s" % n(-b + rc))
        wr.raw("G2 X%s Y%s I%s J0." % (n(a - rc), n(-b), n(-rc)))
        wr.raw("G1 X%s" % n(-a + rc))
        wr.raw("G2 X%s Y%s I0. J%s" % (n(-a), n(-b + rc), n(rc)))
        wr.raw("G1 Y0.")
        wr.raw("G3 X%s Y%s I%s J0." % (n(-a - lead), n(lead), n(-lead)))
        wr.raw("G40 G1 X-60.")
        wr.raw("G0 Z2.")
    wr.raw("G0 Z15.")
    wr.raw("M9")
    wr.raw("M5")
    wr.raw("G28 G91 Z0.")
    wr.raw("G90")
    wr.raw("M30")
    wr.raw("%")
    wr.write(os.path.join(HERE, "fanuc_cutter_comp", "program.nc"))


FANUC_BORING_MODAL = """%
O3100 (PLATE 100X80X30 - BACK BORE, BORE, SPOT - SHOP PROGRAM)
(STOCK ON PARALLELS, WORK ZERO TOP CENTRE)
N10 G21 G90 G17 G40 G49 G80 G94
N20 T1 M6 (DRILL D10 THROUGH)
N30 G54 G0 X-30. Y-20. S1800 M3
N40 G43 H1 Z20. M8
N50 G98 G81 Z-32. R2. F120.
N60 X30.
N70 G80
N80 G0 Z50. M9
N90 G91 G28 Z0. M5
N100 G90
N110 T2 M6 (BACK BORING BAR - COUNTERBORE FROM BELOW)
N120 G0 X-30. Y-20. S600 M3
N130 G43 H2 Z20.
N140 G98 G87 Z-26. R-34. Q1.5 F60.
N150 X30.
N160 G80
N170 G0 Z50.
N180 G91 G28 Z0. M5
N190 G90
N200 T3 M6 (BORING BAR D12 - OPERATOR RETRACTS)
N210 G0 X0 Y15. S900 M3
N220 G43 H3 Z20.
N230 G99 G88 Z-12. R2. P500 F50.
N240 G80
N250 G0 Z50.
N260 G91 G28 Z0. M5
N270 G90
N280 T4 M6 (SPOT DRILL - MODAL MACRO CALL)
N290 G0 X-30. Y20. S2500 M3
N300 G43 H4 Z20.
N310 G66 P9010 A1.5 R2. C20. F150.
N320 X-30. Y20.
N330 X-10.
N340 X10.
N350 X30.
N360 G67
N370 G0 Z50.
N380 G91 G28 Z0. M5
N390 G90
N400 M30
O9010 (SPOT AT THE CURRENT X Y: A DEPTH, R LEVEL, C RETURN, F FEED)
IF [#1 EQ #0] THEN #3000 = 1 (DEPTH A MISSING)
G0 Z#18
G1 Z-#1 F#9
G0 Z#3
M99
%
"""


def write_text(name, file_name, text):
    os.makedirs(os.path.join(HERE, name), exist_ok=True)
    with open(os.path.join(HERE, name, file_name), "w", newline="") as f:
        f.write(text)


if __name__ == "__main__":
    fusion360(inch=False)
    fusion360(inch=True)
    mastercam()
    powermill()
    nx()
    freecad()
    haas()
    write_text("linuxcnc_macros", "program.ngc", LINUXCNC_MACROS)
    write_text("fanuc_macro_b", "program.nc", FANUC_MACRO_B)
    write_text("fanuc_boring_modal", "program.nc", FANUC_BORING_MODAL)
    five_axis_tcp()
    fanuc_cutter_comp()
