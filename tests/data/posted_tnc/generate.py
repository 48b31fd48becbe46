#!/usr/bin/env python3
"""Writes the Heidenhain TNC corpus (tests/data/posted_tnc/<style>/program.h) and, beside each,
the same tool path as an ISO G-code program (program_iso.nc) for the test that both give the
same poses. Written for vmsim's tests (geometry computed here, the form imitated from what
hyperMILL, NX and PowerMill posts write for an iTNC 530 / TNC 640); nothing was copied from a
real program. Not run by CI: the programs are checked in; run it again only to change the
corpus (python3 generate.py from this folder).

The machine is samples/machines/mikron_ucp710.yaml (X Y Z + A about X, C about Z, table-table):
the tool axis in W of A, C is (sin A sin C, sin A cos C, cos A).
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def tnc(value, decimals=3, fixed=False):
    """A TNC number: always signed ("X+10.5", "X-0.25", "X+0"); fixed: all decimals kept."""
    v = round(value, decimals)
    if v == 0:
        v = 0.0
    text = f"{abs(v):.{decimals}f}"
    if not fixed:
        text = text.rstrip("0").rstrip(".")
    return ("-" if v < 0 else "+") + text


def iso(value, decimals=3):
    """A Fanuc number: "10.", "-0.25"."""
    v = round(value, decimals)
    if v == 0:
        v = 0.0
    text = f"{v:.{decimals}f}".rstrip("0")
    return text


class Tnc:
    """Numbered blocks from 0, as the TNC stores them."""

    def __init__(self):
        self.lines = []

    def __call__(self, text):
        self.lines.append(f"{len(self.lines)} {text}")

    def write(self, path):
        with open(path, "w", newline="") as f:
            f.write("\n".join(self.lines) + "\n")


class Iso:
    def __init__(self):
        self.lines = []

    def __call__(self, text):
        self.lines.append(text)

    def write(self, path):
        with open(path, "w", newline="") as f:
            f.write("\n".join(self.lines) + "\n")


def write_part(folder, description, tool, setup_z, toolpath="program.h"):
    with open(os.path.join(HERE, folder, "part.yaml"), "w", newline="") as f:
        f.write(f"# Heidenhain TNC corpus (tests/data/posted_tnc/README.md): {folder}.\n")
        f.write(f"name: {folder}\n")
        f.write(f'description: "{description}"\n')
        f.write("machine: ../../../../samples/machines/mikron_ucp710.yaml\n")
        f.write(f"toolpath: {toolpath}\n")
        f.write(f"tools: [{tool}]\n")
        f.write("# no stock: the program's BLK FORM is the stock\n")
        f.write("setup:\n")
        f.write(f"  work_offsets_mm: {{G54: [0, 0, {setup_z}]}}   # the preset: the stock's top centre\n")
        f.write("feeds: {}                           # the program's own feeds\n")


# --- 1. hyperMILL, 3-axis pocket -----------------------------------------------------------------

def hypermill_3axis():
    """hyperMILL style for a TNC 640, 3-axis: BLK FORM, TOOL CALL with DL/DR, M91 retracts,
    CYCL DEF 32 with HSC-MODE, feeds in Q parameters (FN 0), a helical entry (C with Z), a
    contour with RND and CHF, CT and CR arcs, a full circle about CC; unsigned trailing zeros
    dropped."""
    folder = "hypermill_3axis"
    os.makedirs(os.path.join(HERE, folder), exist_ok=True)
    t, g = Tnc(), Iso()
    t("BEGIN PGM POCKET MM")
    t(";hyperMILL TNC640 / 3X POCKET")
    t("BLK FORM 0.1 Z X-50 Y-40 Z-30")
    t("BLK FORM 0.2 X+50 Y+40 Z+0")
    t("* - T1 FLAT D10")
    t("TOOL CALL 1 Z S8000 DL+0 DR+0")
    t("L Z-5 R0 FMAX M91")
    t("CYCL DEF 32.0 TOLERANZ")
    t("CYCL DEF 32.1 T0.01")
    t("CYCL DEF 32.2 HSC-MODE:0")
    t("FN 0: Q1 = +300 ;PLUNGE")
    t("FN 0: Q2 = +1200 ;CUT")
    t("Q3 = Q2 * 0.5 ;CORNER")
    g("%")
    g("O1000 (POCKET)")
    g("G90 G94 G17 G21 G40 G80")
    g("G53 G0 Z-5.")
    g("T1 M6")
    g("S8000 M3")
    g("G64 P0.01")
    # Approach over the helix start.
    t("L X+5 Y+0 R0 FMAX M3")
    t("L Z+2 FMAX")
    g("G0 G54 G43 H1 X5. Y0.")
    g("Z2.")
    # Helix: 5 full turns of radius 5 down to Z-3, then one flat turn.
    t("CC X+0 Y+0")
    z = 2.0
    for k in range(5):
        z -= 1.0
        t(f"C X+5 Y+0 Z{tnc(z)} DR+ FQ1")
        g(f"G3 X5. Y0. Z{iso(z)} I-5. J0. F300.")
    t("C X+5 Y+0 DR+")
    g("G3 X5. Y0. I-5. J0.")
    # The contour at Z-3: RND R8 at three corners, CHF 4 at one.
    t("L X+0 Y-20 FQ2")
    g("G1 X0. Y-20. F1200.")
    corners = [((30, -20), (30, 20), ("RND", 8)), ((30, 20), (-30, 20), ("RND", 8)),
               ((-30, 20), (-30, -20), ("CHF", 4)), ((-30, -20), (0, -20), ("RND", 8))]
    previous = (0.0, -20.0)
    iso_lines = []
    for corner, nxt, (kind, size) in corners:
        t(f"L X{tnc(corner[0])} Y{tnc(corner[1])}")
        t(f"RND R{size} FQ3" if kind == "RND" else f"CHF {size}")
        # The ISO twin: the corner resolved here.
        u1 = unit((corner[0] - previous[0], corner[1] - previous[1]))
        u2 = unit((nxt[0] - corner[0], nxt[1] - corner[1]))
        cross = u1[0] * u2[1] - u1[1] * u2[0]
        deflection = math.atan2(abs(cross), u1[0] * u2[0] + u1[1] * u2[1])
        d = size if kind == "CHF" else size * math.tan(deflection / 2)
        t1 = (corner[0] - d * u1[0], corner[1] - d * u1[1])
        t2 = (corner[0] + d * u2[0], corner[1] + d * u2[1])
        g(f"G1 X{iso(t1[0])} Y{iso(t1[1])}")
        if kind == "CHF":
            g(f"G1 X{iso(t2[0])} Y{iso(t2[1])}")
        else:
            left = cross > 0
            n1 = (-u1[1], u1[0]) if left else (u1[1], -u1[0])
            c = (t1[0] + size * n1[0], t1[1] + size * n1[1])
            g(f"{'G3' if left else 'G2'} X{iso(t2[0])} Y{iso(t2[1])} I{iso(c[0] - t1[0])} "
              f"J{iso(c[1] - t1[1])} F600.")
            g("G1 F1200.")
        previous = corner
        iso_lines.append(nxt)
    t("L X+0 Y-20")
    g("G1 X0. Y-20.")
    # A tangential arc after a line (CT), a radius arc (CR) and a full circle about CC.
    t("L X+0 Y-10")
    g("G1 X0. Y-10.")
    t("CT X+10 Y+0")   # tangent +Y at (0, -10): centre (10, -10), clockwise, r 10
    g("G2 X10. Y0. I10. J0.")
    t("CR X+0 Y+10 R+10 DR+")
    g("G3 X0. Y10. R10.")
    t("L X+0 Y+15")
    g("G1 X0. Y15.")
    t("CC X+0 Y+0")
    t("C X+0 Y+15 DR-")
    g("G2 X0. Y15. I0. J-15.")
    # A finishing raster on the floor at Z-3 (lines).
    t("L Z+2 FMAX")
    g("G0 Z2.")
    y = -14.0
    t(f"L X-20 Y{tnc(y)} FMAX")
    t("L Z-3 FQ1")
    g(f"G0 X-20. Y{iso(y)}")
    g("G1 Z-3. F300.")
    direction = 1
    first = True
    while y <= 14.0 + 1e-9:
        x_end = 20.0 if direction > 0 else -20.0
        t(f"L X{tnc(x_end)}" + (" FQ2" if first else ""))
        g(f"X{iso(x_end)}" + (" F1200." if first else ""))
        first = False
        y += 4.0
        if y <= 14.0 + 1e-9:
            t(f"L Y{tnc(y)}")
            g(f"Y{iso(y)}")
        direction = -direction
    t("L Z+5 FMAX")
    t("L Z-5 R0 FMAX M91")
    t("M30")
    t("END PGM POCKET MM")
    g("G0 Z5.")
    g("G53 G0 Z-5.")
    g("M30")
    g("%")
    t.write(os.path.join(HERE, folder, "program.h"))
    g.write(os.path.join(HERE, folder, "program_iso.nc"))
    write_part(folder, "hyperMILL style for a TNC 640, 3-axis pocket: helix, RND/CHF contour, CT/CR/CC arcs, raster; "
               "Q parameter feeds, CYCL DEF 32 T0.01, M91 retracts, BLK FORM as the stock",
               "{number: 1, type: flat, diameter_mm: 10, length_mm: 60, cutting_length_mm: 30}", 30)


def unit(v):
    n = math.hypot(v[0], v[1])
    return (v[0] / n, v[1] / n)


# --- 2. NX, 3+2 chamfers on two edges --------------------------------------------------------------

def rot_x(a):
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return [[1, 0, 0], [0, c, -s], [0, s, c]]


def rot_z(a):
    c, s = math.cos(math.radians(a)), math.sin(math.radians(a))
    return [[c, -s, 0], [s, c, 0], [0, 0, 1]]


def mat_mul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def mat_vec(a, v):
    return tuple(sum(a[i][k] * v[k] for k in range(3)) for i in range(3))


def nx_3plus2():
    """NX Post Builder style for an iTNC 530, 3+2: fixed 3 decimals, `L A+0 C+0 R0 FMAX`
    first, per face a datum shift (CYCL DEF 7) to the edge, PLANE SPATIAL ... TURN FMAX SEQ-
    TABLE ROT, a zig-zag face with semicircle links (CC / C) in the tilted plane, the retract
    along the tilted Z, PLANE RESET TURN and the datum shift cancelled. Two faces: a 30 deg
    chamfer on the -Y edge (SPA+30) and on the +X edge (SPA+30 SPC+90)."""
    folder = "nx_3plus2"
    os.makedirs(os.path.join(HERE, folder), exist_ok=True)
    t, g = Tnc(), Iso()
    f3 = lambda v: tnc(v, 3, fixed=True)
    t("BEGIN PGM NX_CHAMFER MM")
    t("BLK FORM 0.1 Z X-50.000 Y-40.000 Z-30.000")
    t("BLK FORM 0.2 X+50.000 Y+40.000 Z+0.000")
    t(";OPERATION: CHAMFER_FACES")
    t("TOOL CALL 3 Z S10000")
    t("L Z-5.000 R0 FMAX M91")
    t("L A+0.000 C+0.000 R0 FMAX")
    t("CYCL DEF 32.0 TOLERANCE")
    t("CYCL DEF 32.1 T0.005")
    g("%")
    g("O2000 (NX CHAMFER)")
    g("G90 G94 G17 G21 G40 G80")
    g("G53 G0 Z-5.")
    g("T3 M6")
    g("S10000 M3")
    g("G0 A0. C0.")
    g("G64 P0.005")
    g("G54")
    faces = [((0.0, -40.0, 0.0), 30.0, 0.0, 45.0, 8.0), ((50.0, 0.0, 0.0), 30.0, 90.0, 35.0, 8.0)]
    for origin, spa, spc, half_length, width in faces:
        r = mat_mul(rot_z(spc), rot_x(spa))
        axis = mat_vec(r, (0, 0, 1))
        # Tool axis (sin A sin C, sin A cos C, cos A) with A <= 0.
        a_deg = -math.degrees(math.acos(axis[2]))
        c_deg = math.degrees(math.atan2(-axis[0], -axis[1]))
        to_w = lambda p: tuple(o + q for o, q in zip(origin, mat_vec(r, p)))
        # Approach untilted above the edge, then tilt.
        t(f"L X{f3(origin[0])} Y{f3(origin[1])} R0 FMAX M3")
        t("L Z+40.000 FMAX")
        g(f"G0 G43 H3 X{iso(origin[0])} Y{iso(origin[1])}")
        g("Z40.")
        t("CYCL DEF 7.0 DATUM SHIFT")
        t(f"CYCL DEF 7.1 X{f3(origin[0])}")
        t(f"CYCL DEF 7.2 Y{f3(origin[1])}")
        t(f"CYCL DEF 7.3 Z{f3(origin[2])}")
        t(f"PLANE SPATIAL SPA{f3(spa)} SPB+0.000 SPC{f3(spc)} TURN FMAX SEQ- TABLE ROT")
        g("G43.4 H3")
        g(f"G0 A{iso(a_deg)} C{iso(c_deg)}")
        # The face in the plane: z = -1 (1 mm under the edge along the tilted normal), passes
        # along tilted X every 5 mm in tilted Y, linked by semicircles of radius 2.5.
        depth = -1.0
        y0 = -width
        ys = [y0 + 5.0 * k for k in range(int(width * 2 / 5.0) + 1)]
        p = (-half_length, ys[0], 20.0)
        t(f"L X{f3(p[0])} Y{f3(p[1])} Z{f3(p[2])} FMAX")
        w = to_w(p)
        g(f"G0 X{iso(w[0])} Y{iso(w[1])} Z{iso(w[2])}")
        p = (-half_length, ys[0], depth)
        t(f"L Z{f3(depth)} F800")
        w = to_w(p)
        g(f"G1 X{iso(w[0])} Y{iso(w[1])} Z{iso(w[2])} F800.")
        x = -half_length
        for i, y in enumerate(ys):
            x_end = half_length if i % 2 == 0 else -half_length
            t(f"L X{f3(x_end)} Y{f3(y)} F2500" if i == 0 else f"L X{f3(x_end)} Y{f3(y)}")
            w = to_w((x_end, y, depth))
            g(f"G1 X{iso(w[0])} Y{iso(w[1])} Z{iso(w[2])}" + (" F2500." if i == 0 else ""))
            x = x_end
            if i + 1 < len(ys):
                # Semicircle to the next pass about (x, y + 2.5): counter-clockwise at +X.
                ccw = x > 0
                t(f"CC X{f3(x)} Y{f3(y + 2.5)}")
                t(f"C X{f3(x)} Y{f3(ys[i + 1])} DR{'+' if ccw else '-'}")
                # The ISO twin: the arc in the tilted plane as points every 2 deg.
                sign = 1.0 if ccw else -1.0
                for k in range(1, 91):
                    angle = -math.pi / 2 + sign * math.pi * k / 90.0
                    w = to_w((x + 2.5 * math.cos(angle), y + 2.5 + 2.5 * math.sin(angle), depth))
                    g(f"G1 X{iso(w[0], 4)} Y{iso(w[1], 4)} Z{iso(w[2], 4)}")
        t("L Z+20.000 FMAX")
        w = to_w((x, ys[-1], 20.0))
        g(f"G0 X{iso(w[0])} Y{iso(w[1])} Z{iso(w[2])}")
        t("PLANE RESET TURN FMAX")
        t("CYCL DEF 7.0 DATUM SHIFT")
        t("CYCL DEF 7.1 X+0.000")
        t("CYCL DEF 7.2 Y+0.000")
        t("CYCL DEF 7.3 Z+0.000")
        g("G0 A0. C0.")
        g("G43 H3")  # out of TCP, the tool length kept (as the TNC, which always has it)
    t("L Z-5.000 R0 FMAX M91")
    t("M30")
    t("END PGM NX_CHAMFER MM")
    g("G53 G0 Z-5.")
    g("M30")
    g("%")
    t.write(os.path.join(HERE, folder, "program.h"))
    g.write(os.path.join(HERE, folder, "program_iso.nc"))
    write_part(folder, "NX style for an iTNC 530, 3+2: datum shift to each edge, PLANE SPATIAL TURN, zig-zag face "
               "with CC/C links in the tilted plane, PLANE RESET TURN",
               "{number: 3, type: flat, diameter_mm: 8, length_mm: 60, cutting_length_mm: 20}", 30)


# --- 3. PowerMill, simultaneous 5-axis -----------------------------------------------------------

def powermill_5axis():
    """PowerMill style for a TNC 640, simultaneous 5-axis with M128: a dome spiral, the first
    half as `L X Y Z A C` (rotary words), the second as `LN X Y Z NX NY NZ TX TY TZ` (surface
    normal and tool vector, 7 decimals), M129 before the M91 retract."""
    folder = "powermill_5axis"
    os.makedirs(os.path.join(HERE, folder), exist_ok=True)
    t, g = Tnc(), Iso()
    radius = 25.0

    def pose(polar_deg, azimuth_deg):
        p, a = math.radians(polar_deg), math.radians(azimuth_deg)
        n = (math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p))
        tip = tuple(radius * c for c in n)
        return tip, -polar_deg, math.degrees(math.atan2(-n[0], -n[1])), n

    t("BEGIN PGM DOME5X MM")
    t("BLK FORM 0.1 Z X-30 Y-30 Z+0")
    t("BLK FORM 0.2 X+30 Y+30 Z+26")
    t("TOOL CALL 5 Z S12000")
    t("L Z-5 R0 FMAX M91")
    t("L A+0 C+0 R0 FMAX")
    t("M128")
    g("%")
    g("O3000 (DOME 5X)")
    g("G90 G94 G17 G21 G40 G80")
    g("G53 G0 Z-5.")
    g("T5 M6")
    g("S12000 M3")
    g("G54")
    g("G0 A0. C0.")
    g("G43.4 H5")
    tip, a_deg, c_deg, n = pose(15.0, 0.0)
    safe = tuple(v + 40.0 * c for v, c in zip(tip, n))
    t(f"L X{tnc(safe[0])} Y{tnc(safe[1])} Z{tnc(40.0 + radius)} R0 FMAX M3")
    t(f"L A{tnc(a_deg)} C{tnc(c_deg)} FMAX")
    t(f"L X{tnc(safe[0])} Y{tnc(safe[1])} Z{tnc(safe[2])} FMAX")
    g(f"G0 X{iso(safe[0])} Y{iso(safe[1])} Z{iso(40.0 + radius)}")
    g(f"G0 A{iso(a_deg)} C{iso(c_deg)}")
    g(f"G0 X{iso(safe[0])} Y{iso(safe[1])} Z{iso(safe[2])}")
    t(f"L X{tnc(tip[0])} Y{tnc(tip[1])} Z{tnc(tip[2])} F500")
    g(f"G1 X{iso(tip[0])} Y{iso(tip[1])} Z{iso(tip[2])} F500.")
    t("L F1000")
    g("F1000.")
    # 2 turns, a point every 1 deg (finer steps than a chord tolerance needs: the table turns
    # C between points, and the chord in W must stay within 1 um of the arc), polar 15 -> 45 deg.
    steps = 2 * 360
    previous_c = c_deg
    for k in range(1, steps + 1):
        tip, a_deg, c_deg, n = pose(15.0 + 30.0 * k / steps, 1.0 * k)
        while c_deg - previous_c > 180.0:
            c_deg -= 360.0
        while c_deg - previous_c < -180.0:
            c_deg += 360.0
        previous_c = c_deg
        if k <= steps // 2:
            t(f"L X{tnc(tip[0])} Y{tnc(tip[1])} Z{tnc(tip[2])} A{tnc(a_deg)} C{tnc(c_deg)}")
            g(f"G1 X{iso(tip[0])} Y{iso(tip[1])} Z{iso(tip[2])} A{iso(a_deg)} C{iso(c_deg)}")
        else:
            if k == steps // 2 + 1:
                g("G43.5 H5")
            vec = " ".join(f"{name}{tnc(v, 7, fixed=True)}" for name, v in zip(("TX", "TY", "TZ"), n))
            nrm = " ".join(f"{name}{tnc(v, 7, fixed=True)}" for name, v in zip(("NX", "NY", "NZ"), n))
            t(f"LN X{tnc(tip[0])} Y{tnc(tip[1])} Z{tnc(tip[2])} {nrm} {vec}")
            g(f"G1 X{iso(tip[0])} Y{iso(tip[1])} Z{iso(tip[2])} I{iso(n[0], 7)} J{iso(n[1], 7)} K{iso(n[2], 7)}")
    # The retract along the tool with the rotary words again (the table then turns back from
    # known words), 40 mm along the tool axis.
    retract = tuple(v + 40.0 * c for v, c in zip(tip, n))
    t(f"L X{tnc(retract[0])} Y{tnc(retract[1])} Z{tnc(retract[2])} A{tnc(a_deg)} C{tnc(c_deg)} FMAX")
    g("G43.4 H5")
    g(f"G0 X{iso(retract[0])} Y{iso(retract[1])} Z{iso(retract[2])} A{iso(a_deg)} C{iso(c_deg)}")
    t("L A+0 C+0 FMAX")
    t("M129")
    t("L Z-5 R0 FMAX M91")
    t("M30")
    t("END PGM DOME5X MM")
    g("G0 A0. C0.")
    g("G49")
    g("G53 G0 Z-5.")
    g("M30")
    g("%")
    t.write(os.path.join(HERE, folder, "program.h"))
    g.write(os.path.join(HERE, folder, "program_iso.nc"))
    write_part(folder, "PowerMill style for a TNC 640, simultaneous 5-axis under M128: a dome spiral as L X Y Z A C, "
               "then as LN with the surface normal and the tool vector",
               "{number: 5, type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60, cutting_length_mm: 10}", 0)


# --- 4. hyperMILL, contour with APPR / DEP, depth passes by LBL, drilling cycles ------------------

def tnc_drilling(number, q, x, y, z, surface_shift=0.0):
    """The moves [(rapid, x, y, z, feed)] of TNC cycle 200 / 203 from the tool at z, as the TNC 640
    manual describes them (written here again, apart from the reader: the ISO twin's motion)."""
    surface = q[203] + surface_shift
    clearance = surface + q[200]
    second = surface + max(q[204], q[200])
    bottom = surface + q[201]
    moves = []
    at = [z]

    def move(rapid, level, feed=None):
        if abs(level - at[0]) > 1e-12:
            moves.append((rapid, x, y, level, feed))
            at[0] = level

    move(True, clearance)
    level, stroke, breaks = surface, q[202], 0
    retract_feed = q.get(208, 0) or q[206]
    while level > bottom:
        level = max(level - stroke, bottom)
        move(False, level, q[206])
        if level <= bottom:
            break
        if number == 203 and breaks < q[213]:
            breaks += 1
            move(False, level + q[256], retract_feed)
        else:
            breaks = 0
            if number == 203:
                move(False, clearance, retract_feed)
            else:
                move(True, clearance)
            move(True, level + q[200])
        if number == 203:
            shorter = max(stroke - q[212], q[205])
            stroke = shorter if shorter > 0 else stroke
    if number == 203:
        move(False, clearance, retract_feed)
    else:
        move(True, clearance)
    move(True, second)
    return moves


def hypermill_contour_holes():
    """hyperMILL style for a TNC 640, 3-axis: an outside contour approached with APPR PLT (polar,
    about CC) and left with DEP LT, under RL; two depth passes as a program section repeat
    (LBL 1 ... CALL LBL 1 REP 1); drilling cycles 200 (CYCL CALL POS in the subprogram LBL 2)
    and 203 (M99) with their Q parameter lines. The ISO twin writes the tool centre's path
    (computed here: the rectangle offset outside by the tool radius, corners rolled on arcs)
    and each cycle's moves as G0 / G1."""
    folder = "hypermill_contour_holes"
    os.makedirs(os.path.join(HERE, folder), exist_ok=True)
    t, g = Tnc(), Iso()
    r = 5.0
    t("BEGIN PGM BOSS MM")
    t(";hyperMILL TNC640 / CONTOUR + DRILLING")
    t("BLK FORM 0.1 Z X-50 Y-40 Z-30")
    t("BLK FORM 0.2 X+50 Y+40 Z+0")
    t("* - T1 FLAT D10")
    t("TOOL CALL 1 Z S8000")
    t("L X+20 Y-45 Z+50 R0 FMAX M3")
    t("L Z+2 FMAX")
    g("%")
    g("O1001 (BOSS)")
    g("G90 G94 G17 G21 G40 G80")
    g("T1 M6")
    g("S8000 M3")
    g("G0 G54 G43 H1 X20. Y-45. Z50.")
    g("Z2.")
    # Two passes, 2 mm each: the section LBL 1 .. CALL LBL 1 REP 1, the depth in Q10.
    t("* - CONTOUR")
    t("FN 0: Q10 = +0 ;DEPTH")
    t("LBL 1")
    t("Q10 = Q10 - 2")
    t("L X+20 Y-45 R0 FMAX")
    t("L Z+Q10 F300")
    t("CC X+0 Y+0")
    t("APPR PLT PR+20 PA-90 LEN10 RL F600")
    for x, y in ((-30, -20), (-30, 20), (30, 20), (30, -20), (0, -20)):
        t(f"L X{tnc(x)} Y{tnc(y)}")
    t("DEP LT LEN10 F600")
    t("L Z+2 FMAX")
    t("CALL LBL 1 REP1")
    for depth in (-2.0, -4.0):
        g("G0 X20. Y-45.")
        g(f"G1 Z{iso(depth)} F300.")
        # APPR LT at PA (0, -20), t = (-1, 0), n = (0, -1) (RL, the outside): to PH + r n
        # = (10, -25) at the motion before's feed, then to PA + r n = (0, -25).
        g("X10. Y-25.")
        g("X0. F600.")
        # The rectangle clockwise, offset outside by r; convex corners rolled on radius r.
        g(f"X-30.")
        g(f"G2 X-35. Y-20. I0. J5.")
        g(f"G1 Y20.")
        g(f"G2 X-30. Y25. I5. J0.")
        g(f"G1 X30.")
        g(f"G2 X35. Y20. I0. J-5.")
        g(f"G1 Y-20.")
        g(f"G2 X30. Y-25. I-5. J0.")
        g(f"G1 X0.")
        # DEP LT LEN10: from PE + r n = (0, -25) to PE + LEN t + r n = (-10, -25).
        g("X-10.")
        g("G0 Z2.")
    t("L Z+50 R0 FMAX")
    g("G0 Z50.")
    # Drilling: cycle 200 at two points (CYCL CALL POS in LBL 2), cycle 203 at one (M99).
    q200 = {200: 2.0, 201: -8.0, 206: 250.0, 202: 3.0, 210: 0.0, 203: 0.0, 204: 20.0, 211: 0.2}
    q203 = {200: 2.0, 201: -12.0, 206: 200.0, 202: 4.0, 210: 0.0, 203: 0.0, 204: 20.0, 212: 1.0,
            213: 2, 205: 2.0, 211: 0.0, 208: 800.0, 256: 0.3, 395: 0}
    names = {200: "SET-UP CLEARANCE", 201: "DEPTH", 206: "FEED RATE FOR PLNGNG", 202: "PLUNGING DEPTH",
             210: "DWELL TIME AT TOP", 203: "SURFACE COORDINATE", 204: "2ND SET-UP CLEARANCE",
             211: "DWELL TIME AT DEPTH", 212: "DECREMENT", 213: "NR OF BREAKS", 205: "MIN. PLUNGING DEPTH",
             208: "RETRACTION FEED RATE", 256: "DIST FOR CHIP BRKNG", 395: "DEPTH REFERENCE"}
    t("* - DRILLING")
    t("CYCL DEF 200 DRILLING ~")
    keys = list(q200)
    for k in keys:
        t(f"  Q{k}={tnc(q200[k])} ;{names[k]}" + (" ~" if k != keys[-1] else ""))
    t("CALL LBL 2")
    z = 50.0
    for hx, hy in ((-15.0, -8.0), (-15.0, 8.0)):
        g(f"G0 X{iso(hx)} Y{iso(hy)}")  # above the surface: in the plane first
        for rapid, x, y, level, feed in tnc_drilling(200, q200, hx, hy, z):
            g(f"G0 Z{iso(level)}" if rapid else f"G1 Z{iso(level)} F{iso(feed)}")
            z = level
    t("CYCL DEF 203 UNIVERSAL DRILLING ~")
    keys = list(q203)
    for k in keys:
        t(f"  Q{k}={tnc(q203[k])} ;{names[k]}" + (" ~" if k != keys[-1] else ""))
    t("L X+15 Y+0 R0 FMAX M99")
    g("G0 X15. Y0.")
    for rapid, x, y, level, feed in tnc_drilling(203, q203, 15.0, 0.0, z):
        g(f"G0 Z{iso(level)}" if rapid else f"G1 Z{iso(level)} F{iso(feed)}")
    t("L Z+50 R0 FMAX")
    t("M30")
    t("* - HOLES")
    t("LBL 2")
    t("CYCL CALL POS X-15 Y-8 Z+0 FMAX")
    t("CYCL CALL POS X-15 Y+8 Z+0 FMAX")
    t("LBL 0")
    t("END PGM BOSS MM")
    g("G0 Z50.")
    g("M30")
    g("%")
    t.write(os.path.join(HERE, folder, "program.h"))
    g.write(os.path.join(HERE, folder, "program_iso.nc"))
    write_part(folder, "hyperMILL style for a TNC 640, 3-axis: an outside contour with APPR PLT / DEP LT under RL in "
               "two depth passes (LBL 1 ... CALL LBL 1 REP1), drilling cycles 200 (CYCL CALL POS in a subprogram) "
               "and 203 (M99)",
               "{number: 1, type: flat, diameter_mm: 10, length_mm: 60, cutting_length_mm: 30}", 30)


if __name__ == "__main__":
    hypermill_3axis()
    nx_3plus2()
    powermill_5axis()
    hypermill_contour_holes()
