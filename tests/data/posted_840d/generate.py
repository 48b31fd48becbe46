#!/usr/bin/env python3
"""Writes the Siemens 840D corpus (tests/data/posted_840d/<style>/program.mpf and part.yaml):
Sinumerik 840D programs as NX, hyperMILL and PowerMill posts write them (3-axis, 3+2 with
CYCLE800, simultaneous 5-axis with TRAORI), and one part written twice, as an ISO (Fanuc)
program and as an 840D program with the same NC modes, whose surfaces must agree. Geometry is
computed here, the format of each post imitated from what those posts write (preamble, tool
change, CYCLE832, frames, arc forms, number format); nothing was copied from a real program.
Not run by CI: the programs are checked in (python3 generate.py from this folder).

The work zero is the stock's top centre (G54 in each part file's set-up); the machine is the
Mikron UCP710 sample (XYZ + A C table, A -120..30 deg).
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))
MACHINE = "../../../../samples/machines/mikron_ucp710.yaml"


def f3(v):
    v = round(v, 3)
    if v == 0:
        v = 0.0
    return f"{v:.3f}".rstrip("0")  # "10." as the posts write integers


def f4(v):
    """4 decimals, trailing zeros dropped ("X-45.8")."""
    v = round(v, 4)
    if v == 0:
        v = 0.0
    return f"{v:.4f}".rstrip("0")


def f6(v):
    v = round(v, 6)
    if v == 0:
        v = 0.0
    return f"{v:.6f}"


def write(folder, name, lines, part):
    os.makedirs(os.path.join(HERE, folder), exist_ok=True)
    with open(os.path.join(HERE, folder, name), "w", newline="\n") as out:
        out.write("\n".join(lines) + "\n")
    with open(os.path.join(HERE, folder, "part.yaml"), "w", newline="\n") as out:
        out.write(part)


class Numbered:
    """N numbers as the 840D posts write them (step 10 or 2)."""

    def __init__(self, step=10, start=None):
        self.lines = []
        self.n = 0
        self.step = step

    def __call__(self, text, numbered=True):
        if numbered:
            self.n += self.step
            text = f"N{self.n} {text}"
        self.lines.append(text)


def nx_3axis():
    """NX (Post Builder, Sinumerik 840D sl library post): DEF'd _camtolerance for CYCLE832,
    the tool by name, G54 then a contour of G1 / G2 / G3 (I J incremental) and a 3-D raster of
    short segments over a bump with a ball mill, CYCLE832() at the end."""
    w = Numbered(10)
    w("%_N_NX_3AXIS_MPF", numbered=False)
    w(";$PATH=/_N_MPF_DIR", numbered=False)
    w(";NX generated program - SINUMERIK 840D sl", numbered=False)
    w("DEF REAL _camtolerance")
    w("G40 G17 G710 G94 G90 G60 G601 FNORM")
    w(";Operation : CONTOUR_FINISH")
    w("T=\"BALL10\"")
    w("M6")
    w("D1")
    w("_camtolerance=0.01")
    w("CYCLE832(_camtolerance,_SEMIFIN,1)")
    w("S10000 M3")
    w("G54")
    w("G0 X-45. Y-35.")
    w("Z10.")
    w("G1 Z-1. F500.")
    # A rounded rectangle 80 x 60, corner radius 8, clockwise with G2.
    hw, hh, r = 40.0, 30.0, 8.0
    w(f"X{f3(-hw)} Y{f3(-hh + r)} F2000.")
    w(f"Y{f3(hh - r)}")
    w(f"G2 X{f3(-hw + r)} Y{f3(hh)} I{f3(r)} J0.0")
    w(f"G1 X{f3(hw - r)}")
    w(f"G2 X{f3(hw)} Y{f3(hh - r)} I0.0 J{f3(-r)}")
    w(f"G1 Y{f3(-hh + r)}")
    w(f"G2 X{f3(hw - r)} Y{f3(-hh)} I{f3(-r)} J0.0")
    w(f"G1 X{f3(-hw + r)}")
    w(f"G2 X{f3(-hw)} Y{f3(-hh + r)} I0.0 J{f3(r)}")
    w("G0 Z10.")
    w(";Operation : RASTER_BUMP")
    w("_camtolerance=0.005")
    w("CYCLE832(_camtolerance,_FINISH,1)")
    # A zig-zag raster in X over a cosine bump (ball tip on the surface), 0.5 mm points.
    def z_of(x, y):
        d = math.hypot(x, y)
        return -6.0 + (4.0 * (1 + math.cos(math.pi * d / 20.0)) / 2.0 if d < 20.0 else 0.0)
    first = True
    for k, y in enumerate([-20.0 + 2.5 * i for i in range(17)]):
        xs = [-30.0 + 0.5 * i for i in range(121)]
        if k % 2:
            xs.reverse()
        if first:
            w(f"G0 X{f3(xs[0])} Y{f3(y)}")
            w(f"G1 Z{f3(z_of(xs[0], y))} F800.")
            first = False
        else:
            w(f"G1 Y{f3(y)} Z{f3(z_of(xs[0], y))}")
        for i, x in enumerate(xs[1:]):
            w(f"X{f3(x)} Z{f3(z_of(x, y))}" + (" F3000." if i == 0 and k == 0 else ""))
    w("G0 Z50.")
    w("CYCLE832()")
    w("M5")
    w("M30")
    part = f"""# Siemens 840D corpus (tests/data/posted_840d/README.md): nx_3axis.
name: nx_3axis
description: "NX Sinumerik 840D post: DEF REAL _camtolerance, CYCLE832(_camtolerance, _SEMIFIN / _FINISH, 1), a G2 contour and a 3-D raster of 0.5 mm segments over a bump"
machine: {MACHINE}
toolpath: program.mpf
tool: {{type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60, cutting_length_mm: 20}}
stock: {{box: {{min_mm: [-50, -40, -20], max_mm: [50, 40, 0]}}}}
setup:
  work_offsets_mm: {{G54: [0, 0, 30]}}   # the work zero: the stock's top centre, on the table
feeds: {{}}                           # the program's own feeds; reference at 1 % of them
"""
    write("nx_3axis", "program.mpf", w.lines, part)


def hypermill_3plus2():
    """hyperMILL (Sinumerik 840D post): R parameters for the safety and retract planes, the
    swivel by CYCLE800 axis by axis (the plane tilted 20 deg about X), CYCLE832 with G642, a
    pocket on the tilted plane with CIP arcs at its ends, the swivel reset by CYCLE800(), TRAFOOF."""
    w = Numbered(1)
    w(";hyperMILL - SINUMERIK 840D - 3+2 INCLINED FACE", numbered=False)
    w("G17 G40 G90 G71 G94")
    w("TRAFOOF")
    w("R1=50 ;RETRACT PLANE")
    w("R2=2 ;SAFETY DISTANCE")
    w("R3=-0.5 ;DEPTH")
    w("T1 M6")
    w("D1")
    w("S9000 M3")
    w("G54")
    w("CYCLE800(1,\"TC1\",200000,57,0,0,0,-20,0,0,0,0,0,1,100,1)")
    w("CYCLE832(0.01,_SEMIFIN,1)")
    w("G642")
    w("G0 X-25 Y-15")
    w("G0 Z=R1")
    w("G0 Z=R2")
    w("G1 Z=R3 F400")
    # Passes along X, each pass joined to the next by a CIP half circle (stepover 7.5 mm).
    for k in range(4):
        y = -15.0 + 10.0 * k
        x_end = 25.0 if k % 2 == 0 else -25.0
        w(f"G1 X{f3(x_end)} F1800")
        if k < 3:
            side = 1.0 if k % 2 == 0 else -1.0
            w(f"CIP X{f3(x_end)} Y{f3(y + 10.0)} I1={f3(x_end + side * 5.0)} J1={f3(y + 5.0)} K1=R3")
    w("G0 Z=R1")
    w("CYCLE800()")
    w("G0 X0 Y0 Z50")
    w("M5")
    w("M30")
    part = f"""# Siemens 840D corpus (tests/data/posted_840d/README.md): hypermill_3plus2.
name: hypermill_3plus2
description: "hyperMILL Sinumerik 840D post: R parameters, CYCLE800 axis by axis (20 deg about X), CYCLE832 + G642, passes joined by CIP arcs on the tilted plane, CYCLE800() reset"
machine: {MACHINE}
toolpath: program.mpf
tools: [{{number: 1, type: flat, diameter_mm: 10, length_mm: 60, cutting_length_mm: 25}}]
stock: {{box: {{min_mm: [-40, -30, -30], max_mm: [40, 30, 0]}}}}
setup:
  work_offsets_mm: {{G54: [0, 0, 30]}}   # the work zero: the stock's top centre, on the table
feeds: {{}}                           # the program's own feeds; reference at 1 % of them
"""
    write("hypermill_3plus2", "program.mpf", w.lines, part)


def powermill_5axis():
    """PowerMill (Sinumerik 840D 5-axis post): TRAORI, ORIWKS, ORIVECT, CYCLE832, COMPCAD, SOFT,
    FFWON, X Y Z and the tool vector A3 B3 C3 (6 decimals) on every point of a spiral over a
    dome (tool normal to it), the tool vector back to +Z at the safe height, TRAFOOF."""
    w = Numbered(2)
    w("%_N_PM_DOME_MPF", numbered=False)
    w(";PowerMill - SINUMERIK 840D 5X", numbered=False)
    w("G17 G40 G71 G90 G94")
    w("T=\"BALL10\" M6")
    w("D1")
    w("S12000 M3")
    w("G54")
    w("CYCLE832(0.005,_FINISH,1)")
    # The rotary axes pre-positioned at the first orientation (the branch with A <= 0; the
    # Mikron's A travel is -120..30 deg), as the post does before TRAORI.
    w("G0 A-15. C-90.")
    w("TRAORI")
    w("ORIWKS")
    w("ORIVECT")
    w("G642 SOFT FFWON COMPCAD")
    radius = 25.0

    def pose(polar_deg, azimuth_deg):
        p, a = math.radians(polar_deg), math.radians(azimuth_deg)
        n = (math.sin(p) * math.cos(a), math.sin(p) * math.sin(a), math.cos(p))
        return tuple(radius * c for c in n), n

    tip, n = pose(15.0, 0.0)
    w(f"G0 X{f3(tip[0] + 40 * n[0])} Y{f3(tip[1] + 40 * n[1])} Z{f3(tip[2] + 40 * n[2])} "
      f"A3={f6(n[0])} B3={f6(n[1])} C3={f6(n[2])}")
    w(f"G1 X{f3(tip[0] + 2 * n[0])} Y{f3(tip[1] + 2 * n[1])} Z{f3(tip[2] + 2 * n[2])} F500")
    w(f"X{f3(tip[0])} Y{f3(tip[1])} Z{f3(tip[2])} F2000")
    # A spiral from 15 to 45 deg of polar angle over 3 turns, 2 deg of azimuth per point.
    steps = 3 * 180
    for k in range(1, steps + 1):
        polar = 15.0 + 30.0 * k / steps
        tip, n = pose(polar, 2.0 * k)
        w(f"X{f3(tip[0])} Y{f3(tip[1])} Z{f3(tip[2])} A3={f6(n[0])} B3={f6(n[1])} C3={f6(n[2])}")
    w(f"G1 X{f3(tip[0] + 5 * n[0])} Y{f3(tip[1] + 5 * n[1])} Z{f3(tip[2] + 5 * n[2])}")
    w(f"G0 X{f3(tip[0] + 40 * n[0])} Y{f3(tip[1] + 40 * n[1])} Z{f3(tip[2] + 40 * n[2])}")
    w("G0 Z80 A3=0 B3=0 C3=1")
    w("TRAFOOF")
    w("COMPOF")
    w("CYCLE832()")
    w("M5")
    w("M30")
    part = f"""# Siemens 840D corpus (tests/data/posted_840d/README.md): powermill_5axis.
name: powermill_5axis
description: "PowerMill Sinumerik 840D 5-axis post: TRAORI ORIWKS ORIVECT, CYCLE832 + G642 SOFT FFWON COMPCAD, X Y Z A3 B3 C3 on a spiral over a dome R25"
machine: {MACHINE}
toolpath: program.mpf
tool: {{type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60, cutting_length_mm: 10}}
stock: {{box: {{min_mm: [-30, -30, 0], max_mm: [30, 30, 26]}}}}
setup:
  work_offsets_mm: {{G54: [0, 0, 0]}}   # the work zero: the dome's centre, on the table
feeds: {{}}                           # the program's own feeds; reference at 1 % of them
"""
    write("powermill_5axis", "program.mpf", w.lines, part)


def twin():
    """One part written twice with the same NC modes (exact stops, no jerk limit, the machine's
    feedforward): an ISO (Fanuc) program and an 840D program (G60 BRISK FFWON, CR= and I J
    arcs, a TRANS frame where the ISO program shifts its coordinates by hand)."""
    iso = ["%", "O4000 (TWIN - ISO)", "G21 G90 G94 G17 G40 G49 G80", "G61", "T1 M6", "S8000 M3",
           "G54 G0 X-30. Y-20.", "G43 H1 Z10."]
    mpf = [";TWIN - 840D", "G17 G40 G71 G90 G94", "G60 BRISK FFWON", "T1 M6", "D1", "S8000 M3",
           "G54", "TRANS X5 Y-3", "G0 X-35. Y-17.", "Z10."]
    # The ISO program works in G54; the 840D one in G54 + TRANS X5 Y-3: its numbers are the ISO
    # ones less (5, -3).
    def both(iso_words, x=None, y=None, extra_iso="", extra_mpf=""):
        iso.append(iso_words.format(x=f3(x) if x is not None else "", y=f3(y) if y is not None else "") + extra_iso)
        mpf.append(iso_words.format(x=f3(x - 5) if x is not None else "", y=f3(y + 3) if y is not None else "") + extra_mpf)
    iso.append("G1 Z-2. F300.")
    mpf.append("G1 Z-2. F300.")
    both("G1 X{x} Y{y}", 30.0, -20.0, " F1500.", " F1500.")
    # Quarter arc about (30, -10): I J on ISO, CR= on the 840D.
    iso.append(f"G3 X40. Y-10. I0. J10.")
    mpf.append(f"G3 X{f3(35.0)} Y{f3(-7.0)} CR=10.")
    both("G1 X{x} Y{y}", 40.0, 15.0)
    iso.append("G3 X30. Y25. I-10. J0.")
    mpf.append(f"G3 X{f3(25.0)} Y{f3(28.0)} I-10. J0.")
    both("G1 X{x} Y{y}", -30.0, 25.0)
    both("G1 X{x} Y{y}", -30.0, -20.0)
    iso += ["G0 Z50.", "M30", "%"]
    mpf += ["G0 Z50.", "TRANS", "M30"]
    for folder, name, lines in (("twin_iso", "program.nc", iso), ("twin_840d", "program.mpf", mpf)):
        part = f"""# Siemens 840D corpus (tests/data/posted_840d/README.md): {folder}.
name: {folder}
description: "One part as an ISO program and as an 840D program with the same NC modes (exact stops, no jerk limit, the machine's feedforward): the surfaces must agree"
machine: {MACHINE}
toolpath: {name}
tools: [{{number: 1, type: flat, diameter_mm: 10, length_mm: 60, cutting_length_mm: 25}}]
stock: {{box: {{min_mm: [-45, -35, -10], max_mm: [45, 35, 0]}}}}
setup:
  work_offsets_mm: {{G54: [0, 0, 30]}}   # the work zero: the stock's top centre, on the table
feeds: {{production_mm_per_min: 3000, reference_mm_per_min: 100}}
"""
        write(folder, name, lines, part)




def part1_840d():
    """Sample part 1 of the second paper (samples/parts/part1_tangency, its APT path point for
    point) as the 840D program of the paper's kind: CYCLE832 with a finishing tolerance of
    0.01 mm (G642 blending, SOFT, FFWON, COMPCAD), G1 blocks at F10000, G0 retracts."""
    apt = os.path.join(HERE, "..", "..", "..", "samples", "parts", "part1_tangency", "toolpath.apt")
    w = Numbered(2)
    w("%_N_PART1_TANGENCY_MPF", numbered=False)
    w(";SAMPLE PART 1 - BALL D10 - 840D WITH CYCLE832", numbered=False)
    w("G17 G40 G71 G90 G94")
    w("T1 M6")
    w("D1")
    w("S15000 M3")
    w("G54")
    w("CYCLE832(0.01,_FINISH,1)")
    rapid = False
    motion = None
    with open(apt) as text:
        for line in text:
            line = line.strip()
            if line.startswith("RAPID"):
                rapid = True
                continue
            if not (line.startswith("GOTO/") or line.startswith("FROM/")):
                continue
            x, y, z = (float(v) for v in line.split("/")[1].split(",")[:3])
            code = "G0" if rapid or line.startswith("FROM/") else "G1"
            words = f"X{f4(x)} Y{f4(y)} Z{f4(z)}"
            if code != motion:
                words = f"{code} {words}" + (" F10000" if code == "G1" else "")
                motion = code
            w(words)
            rapid = False
    w("CYCLE832()")
    w("M30")
    part = f"""# Sample part 1 (samples/parts/part1_tangency) as an 840D program with CYCLE832
# (tests/data/posted_840d/README.md): the paper's kind of program.
name: part1_840d
description: "Sample part 1, the APT path point for point as a Sinumerik 840D program: CYCLE832(0.01, _FINISH, 1)"
machine: {MACHINE}
toolpath: program.mpf
tools: [{{number: 1, type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}}]
stock: {{box: {{min_mm: [-40, -5, 0], max_mm: [40, 5, 40]}}}}
setup:
  work_offsets_mm: {{G54: [0, 0, 0]}}   # the work zero: W's origin, as the APT path
design:
  surfaces:
    - {{type: plane, point_mm: [0, 0, 20], normal: [0, 0, 1], x_range_mm: [-46, 0], y_range_mm: [-5, 5]}}
    - {{type: cylinder, axis_point_mm: [0, 0, 35], axis_direction: [0, 1, 0], radius_mm: 15, material: outside, x_range_mm: [0, 7.5], y_range_mm: [-5, 5]}}
    - {{type: plane, point_mm: [7.5, 0, 22.0096189432], normal: [-0.5, 0, 0.866025403784], x_range_mm: [7.5, 42], y_range_mm: [-5, 5]}}
feeds: {{production_mm_per_min: 10000, reference_mm_per_min: 100}}
"""
    write("part1_840d", "program.mpf", w.lines, part)


if __name__ == "__main__":
    nx_3axis()
    hypermill_3plus2()
    powermill_5axis()
    twin()
    part1_840d()
