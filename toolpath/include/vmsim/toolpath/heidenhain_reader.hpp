#pragma once
// Heidenhain TNC conversational (Klartext) programs, as CAM posts write them for the iTNC 530,
// TNC 620/640 and TNC7 (hyperMILL, NX, PowerMill): read into the canonical motion of
// toolpath.hpp, with the common rules written there (errors "file:line:column: 'word': what",
// UTF-8 text, number ranges and sizes, arcs tessellated within ReaderOptions::
// arc_chord_tolerance_m, the expansion limits, the callbacks' errors placed at the block).
//
// The model of the control assumed here (what is emulated, what is approximated):
//  - Blocks: one per line, an optional leading block number (SourceBlock::block_number), words
//    separated by blanks; `;` starts a comment; a line starting with `*` (a structure block) is
//    skipped; `/` (block delete) skips the block with a warning. BEGIN PGM <name> MM|INCH sets
//    the unit (INCH: lengths in inch, F in 0.1 inch/min as on the TNC); END PGM, M2 and M30 end
//    the program. Words are upper case as the TNC writes them (lower case is read too).
//  - Coordinates: X Y Z A B C absolute, IX IY IZ IA IB IC incremental from the last programmed
//    position; an axis not given keeps its position. Numbers as posts write them (+10.5, -.5,
//    10), or a Q parameter with a sign (X+Q1, X-Q1, FQ5, F+Q5).
//  - Q parameters: Q, QL, QR numbered 0 .. 1999, set by `Q1 = <formula>` (+ - * / ^, parentheses,
//    SIN COS TAN ASIN ACOS ATAN (deg) SQRT SQ ABS INT (toward zero) FRAC NEG SGN LN LOG EXP PI)
//    and by FN 0 .. 8 and FN 13 (=, +, -, *, DIV, SQRT, SIN, COS, LEN, ANG). Reading one never
//    set in the program is an error (the control would use what an earlier program left: not
//    simulated); so is Q120 .. Q122 (the axis angles PLANE STAY computes: the control's
//    kinematics). Jumps (FN 9 .. 12) are errors.
//  - Labels and calls: the program runs from a program counter. LBL n / LBL "NAME" marks a place
//    (a label defined twice is an error); CALL LBL n REP k with the label before it and no
//    LBL 0 between is a program section repeat (the section runs k more times; the counter
//    belongs to the CALL block, so sections nest); any other CALL LBL runs the subprogram from
//    LBL n to LBL 0 and returns after the CALL (REP k: k more runs). LBL 0 reached without a
//    call is passed. CALL PGM name runs the file name (".h" added where it has no extension,
//    drive and folders dropped: TNC:\nc\HOLE.H is HOLE.H) from ReaderOptions::
//    subprogram_folder (read_heidenhain: the program's folder) to its END PGM; its blocks and
//    errors name that file; Q parameters are shared (QL too). Errors: an undefined label, LBL 0
//    called, REP not a whole number 0 .. 65534, calls nested beyond ReaderOptions::
//    max_call_depth (a subprogram calling itself), more than ReaderOptions::max_executed_blocks
//    blocks run from the first jump on, a subprogram running off the end of the file.
//  - Machining cycles 200 DRILLING, 201 REAMING, 203 UNIVERSAL DRILLING: CYCL DEF 2xx with its
//    parameters on the lines after it ("Q200=+2 ;SET-UP CLEARANCE", a trailing "~" is in the
//    comment) or on its own line; they are set as Q parameters too; Q206 / Q208 may be FAUTO.
//    Checked when the definition ends (at the CYCL DEF block): Q200 Q201 Q203 Q204 Q206, 200:
//    Q202, 201: Q208, 203: Q202 Q205 Q208 Q212 Q213 (and Q256 where Q213 > 0); Q201 < 0
//    (drilling towards -Z), Q202 > 0, feeds within range, Q395 0. Called by CYCL CALL, CYCL
//    CALL POS X Y Z [FMAX | F] (the TNC's positioning logic: in the plane first where the tool
//    is above the surface, else first up to the 2nd set-up clearance; Z shifts the surface),
//    M99 on an L block (once, at its end point) and M89 (after every positioning L / LN block
//    from there, until M99). The moves (along the tool axis, each level an exact stop) as the
//    TNC 640 manual describes them: FMAX to the set-up clearance Q200 above the surface Q203;
//    200: strokes of Q202 at Q206, after each FMAX out to the set-up clearance and FMAX back to
//    Q200 above the depth reached; 201: Q206 to the depth, out at Q208 (0: Q206); 203: strokes
//    of Q202, each Q212 shorter down to Q205, Q213 chip breaks (back Q256 at Q208) between full
//    retracts (at Q208 to the set-up clearance, FMAX back to Q200 above the depth); out at
//    Q208; all: then FMAX to the 2nd set-up clearance Q204 above the surface where it is higher
//    than Q200. Dwells (PathPoint::dwell_s): Q211 at the depth; Q210 (200, 203) at the set-up
//    clearance after each full retract that goes back into the hole. Errors: a call before a definition, under
//    RL / RR, before the position is known, more points than max_points_per_block; CYCL CALL
//    PAT (PATTERN DEF), cycles 202 204 205 207 208 220 221 and any other cycle number.
//  - Tools: TOOL CALL <n> Z S<rpm> F<feed> DL<mm> DR<mm>: tool n (PathPoint::tool_number; a
//    tool called by "name" gives -1 with a warning), its length from ReaderOptions::
//    tool_length_mm (else default_tool_length_mm, else 0: without a machine the length cancels out), F the FAUTO
//    feed, DL a length allowance: the real tip stays DL short of the programmed point along the
//    tool axis (DL > 0 leaves material), DR the radius allowance used by LN (below). Tool axis Z
//    only (TOOL CALL n X / Y is an error). TOOL DEF is accepted (preselection).
//  - BLK FORM 0.1 Z X Y Z (MIN point) and BLK FORM 0.2 X Y Z (MAX point, or IX IY IZ from MIN),
//    in the coordinates of the preset: Toolpath::stock_box in W. BLK FORM CYLINDER / ROTATION:
//    a warning, no stock.
//  - Frames. The preset (the TNC's reference point) is ReaderOptions::work_offsets_mm
//    [initial_work_offset] (the part file's set-up; none: the identity, as for G-code), its W
//    place machine_axes_W * offset + machine_zero_W_mm. Program coordinates p map to preset
//    coordinates q = d0 + R (d1 + p): d0 the datum shift programmed outside a tilted plane
//    (CYCL DEF 7.0 DATUM SHIFT / 7.1 X / 7.2 Y / 7.3 Z, or TRANS DATUM AXIS; absolute values
//    replace the axes given, IX adds; TRANS DATUM RESET clears), R the tilted working plane,
//    d1 a datum shift programmed inside it (in the tilted axes; PLANE RESET drops it). A frame
//    change does not move the machine: the next motion starts where the tool is.
//     - PLANE SPATIAL SPA SPB SPC (R = Rz(SPC) Ry(SPB) Rx(SPA): rotations about the fixed axes
//       in the order A, B, C), PLANE EULER EULPR EULNU EULROT (Rz Rx Rz), PLANE VECTOR BX BY
//       BZ NX NY NZ (tilted Z along N, X along B made perpendicular to N), PLANE RELATIV SPA |
//       SPB | SPC (one more rotation about the tilted axis), PLANE RESET. Positioning TURN or
//       MOVE: a point that turns the tool about its tip to the plane's Z axis (R e_z in W; at
//       the F given, else in rapid), the rotary axes then being the chain's choice (SEQ, TABLE
//       ROT / COORD ROT and DIST are accepted but not emulated: the inverse kinematics takes
//       the solution nearest the previous pose); STAY: no motion, the next block's rotary words
//       orient the tool. MB <mm> first retracts that far along the tool axis in rapid; MB MAX
//       (to the travel limit) is skipped with a warning. PLANE PROJECTED / POINTS / AXIAL and
//       CYCL DEF 19 are errors.
//  - Poses. Outside M128 and outside a tilted plane, X Y Z (after the frame) are the tool tip
//    compensated by the tool length along the machine's Z: the machine axes are
//    preset + q + (0, 0, L + DL), and the pose of the machine axes X Y Z A B C comes through
//    ReaderOptions::axis_words_to_pose (the table turns the point, as on a TNC without M128);
//    without a machine, rotary words are an error. Under M128 / FUNCTION TCPM (F TCP AXIS POS;
//    M129 / FUNCTION RESET TCPM cancel) or in a tilted plane, q is the tip in the work system
//    fixed on the table: tip_W = preset in W + q + DL * axis, the axis from the block's rotary
//    words through ReaderOptions::rotary_words_to_tool_axis, from LN's TX TY TZ (turned by R),
//    or the axis in force. Rotary words carry over to PathPoint::rotary_words_deg; a block that
//    turns one by 180 deg or more is split into steps of at most 90 deg (as for G-code).
//  - M91 / M92 (in their block only; outside M128 and tilted planes, as on the TNC): the given
//    axes are machine axis positions from the machine datum (M91) or from
//    ReaderOptions::g28_reference_mm (M92: the machine maker's reference, taken as the home);
//    no tool length compensation. Axes not yet known at the first motion: an M91 / M92 block
//    makes the named axes known and the pose comes once all three are; any other block takes
//    them at the G28 reference (with a set-up, outside M128) or at the program's 0, with a
//    warning.
//  - Motions. L X Y Z A B C [RL | RR | R0] [F | FMAX | FAUTO] [M...]: a line (FMAX: a rapid for
//    this block only; F modal, > 0; a feed motion before any F is an error). R+ / R- (paraxial
//    compensation) and FU / FZ (feed per revolution / tooth) are errors. LN X Y Z NX NY
//    NZ [TX TY TZ]: a line whose tip is shifted by DR along the unit surface normal N; TX TY TZ
//    (the tool vector) need M128 / TCPM. Circles in the working plane X/Y, helices with Z:
//     - CC X Y: the centre (pole; an axis left out keeps the current position, IX IY from it;
//       CC X Z / CC Y Z put the next C in the plane Z/X / Y/Z, with DR+ turning from Z to X /
//       from Y to Z as G18 / G19);
//     - C X Y DR+|DR-: an arc about CC (DR+ counter-clockwise), end = start a full circle; start
//       and end radii may differ within ReaderOptions::arc_radius_tolerance_mm / _inch /
//       arc_radius_relative_tolerance, the centre then moved onto the bisector (as for G2/G3);
//     - CR X Y R DR: radius R (R > 0 the arc of at most 180 deg, R < 0 of more);
//     - CT X Y: the arc tangent to the previous contour element at its end;
//     - RND R: a rounding arc of radius R tangent to the lines before and after it; CHF L: a
//       chamfer cutting L off each of the two lines. Both between two straight lines in the
//       working plane (the line before ends at the corner: its point moves to the tangent point);
//       next to an arc, an error. F on RND / CHF: their own feed.
//    LP / CP (polar) and FK (free contour programming) are errors. APPR / DEP LT LN CT LCT and
//    their polar forms PLT PLN PCT PLCT (the point PR PA about the pole CC in the plane X/Y,
//    PA from +X counter-clockwise; incremental IPR / IPA are errors): heidenhain_reader.cpp,
//    "APPR / DEP", and the README.
//  - Radius compensation (cutter_compensation.hpp, as G41 / G42 in G-code): RL keeps the tool
//    centre left of the programmed contour in X/Y, RR right, by the radius of the TOOL CALL's
//    tool (ReaderOptions::cutter_radius_mm by T number, else default_cutter_radius_mm) plus
//    TOOL CALL's DR. RL / RR on an L block start it: that block is the approach and ends normal
//    to the first contour element at its offset start (EntryRule::normal_to_next); they stay in
//    force (written again on later blocks: nothing) until R0 on a later L, whose move goes
//    uncompensated from the last element's offset end to the block's point. L, C, CR, CT, RND,
//    CHF and Z-only lines under it are offset; each element is held one block (an RND / CHF may
//    still cut it back). Errors: no radius, RL / RR under M128 / TCPM or a tilted PLANE, on an
//    arc, the other side without R0, R0 on an arc or on a block without a point, and under it
//    TOOL CALL, PLANE, datum shifts, TCPM / M128, M91 / M92, LN, rotary words; a gouge or an
//    inside arc not larger than the tool (the compensator's errors) at the block that shows it.
//  - NC modes: CYCL DEF 32.0 TOLERANCE / 32.1 T<mm>: PathPoint::corner_tolerance_m (T > 0: the
//    corners are blended within T; T 0: exact stop; 32.1 without T: NaN, the machine's own);
//    32.2 HSC-MODE and TA (rotary tolerance) are accepted, not emulated. Jerk limitation and
//    feedforward are the machine's on a TNC (no program word sets them): unspecified.
//  - Accepted and ignored: M functions other than M2 M30 M89 M91 M92 M99 M128 M129 (spindle,
//    coolant, M126 shortest path, ...; M140 retract and M98 are errors), STOP, FUNCTION MODE MILL.
//    CYCL DEF 9.0 / 9.1 DWELL <seconds>: a dwell where the tool is (PathPoint::dwell_s). Any other keyword or cycle is an error: it may change the
//    geometry.
#include <string>

#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {

/// Reads a Heidenhain TNC conversational program (.h). Throws vmsim::InputError naming the file,
/// line, column and word; also when the file cannot be read or programs no motion.
Toolpath read_heidenhain(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_heidenhain(const std::string& text, const std::string& file_name_for_messages,
                          const ReaderOptions& options = {});

}  // namespace vmsim::toolpath
