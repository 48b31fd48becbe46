#pragma once
// The canonical motion: what the tool path readers (APT/CL, ISO G-code, Siemens 840D) produce,
// and all the planner reads. SI units (m, s), positions and tool axes in the workpiece frame W.
//
// Both readers give the same canonical points for the same motion: a tool tip [m], a unit tool
// axis pointing from the tip to the spindle, the kind of motion, the feed [m/s] (or G93 inverse
// time [1/s]) and the source block. Common rules:
//  - Errors: bad input throws vmsim::InputError "file:line:column: 'word': what is wrong"; nothing
//    is half-returned. A file that programs no tool position at all (empty, comments only, no
//    motion record) is an error ("no motion"), not an empty path.
//  - A cutting move (APT GOTO without RAPID, G1/G2/G3) before any feed rate is an error (never a
//    silent feed of 0).
//  - A motion that ends exactly where the previous point is (same tip, same axis) adds no point.
//  - A zero tool axis vector (APT i,j,k; G43.5 I J K; Siemens A3 B3 C3) is an error; others are
//    normalised.
//  - Text: a UTF-8 byte-order mark at the start is skipped (columns count after it). The file
//    must be UTF-8 (ASCII included): a byte that is not (a Latin-1 0xE9, a cut-short sequence)
//    or a NUL is an error naming its line, column and the byte in hex.
//  - Numbers: finite, not subnormal (4.9e-324), within a double (1e400 is an error "too large",
//    1e-400 "too small"); every error quotes the value as written. Plausible ranges (in mm after
//    UNITS/G20): coordinates, arc centre offsets and radii |v| <= 1e6 mm (also the positions
//    reached incrementally); rotary words |A B C| <= 1e6 deg; feed 1e-3 .. 1e6 mm/min; G93
//    inverse time 1e-3 .. 1e4 1/min; CUTTER diameter 1e-3 .. 1e4 mm, corner radius 0 .. d/2;
//    spindle speed (APT SPINDL, G-code S) |S| <= 1e6 rev/min; APT tolerances (INTOL OUTTOL TOLER
//    LINTOL) and G187 E |t| <= 1e3 mm; N O T H D L M P and G4 dwell values 0 .. 1e9; G numbers
//    0 .. 1000; canned cycle repeats 0 .. 1e6.
//  - Size: a file of at most 1 GiB, a G-code block of at most 64 words, an APT record of at
//    most 4 MiB (continuations joined). Expansion: ReaderOptions::max_points_per_block (an arc's
//    tessellation, a long rotary turn's steps) and max_path_points (the whole path), checked
//    before a block's points are made; the message gives the block's points, the total and the
//    limit. A block turns an arc at most once (a full circle: no P turns count, no TURN=).
//  - Errors from the caller's callbacks (axis_words_to_pose, rotary_words_to_tool_axis) are
//    rethrown at the block, of the same type (InputError or InfeasibleError: a word outside the
//    axis travel); every other failure inside a reader becomes an InputError naming the line.
//
// APT/CL subset (read_apt):
//  - Records `NAME/v1,v2,...`, case-insensitive; a trailing `$` continues the record on the next
//    line; `$$` starts a comment (to the end of the line). PARTNO PPRINT INSERT REMARK TITLE
//    carry free text and are skipped whole.
//  - UNITS/MM | UNITS/INCHES (default mm): lengths and FEDRAT/f that follow are in that unit.
//  - FROM/x,y,z[,i,j,k]: a point of kind rapid (the start pose when first; a warning when not).
//  - GOTO/x,y,z[,i,j,k]: MULTAX/ON (or MULTAX alone): x,y,z,i,j,k, several points allowed as a
//    multiple of 6 values; MULTAX/OFF: x,y,z, several points as a multiple of 3 values, with the
//    current TLAXIS axis; MULTAX never given: 3 values (TLAXIS axis) or 6 values (own axis).
//    A given i,j,k becomes the current tool axis. The point's kind is rapid after RAPID (for the
//    next GOTO only), else linear.
//  - TLAXIS/i,j,k: the tool axis for GOTOs without i,j,k (default +Z). No motion by itself.
//  - FEDRAT/f | FEDRAT/MMPM,f | FEDRAT/f,MMPM | IPM forms: feed per minute (f alone: in the
//    UNITS unit per minute); MMPR/IPR (per revolution) is an error.
//  - CUTTER/d[,r[,e,f,a,b,h]] (APT 7-parameter form): Toolpath::cutter_diameter_m and
//    cutter_corner_radius_m (r defaults to 0; 0 <= r <= d/2).
//  - LOADTL/n[,...]: tool n (PathPoint::tool_number) for the motions that follow.
//  - FINI ends the file. CUTCOM (other than /OFF), CYCLE (other than /OFF) and CIRCLE / MOVARC
//    change the geometry and are errors. Harmless records (SPINDL COOLNT LOADTL END CLPRNT NOPOST
//    MACHIN SELCTL TOOLNO STOP OPSTOP DELAY SEQNO INTOL OUTTOL TOLER PLABEL TLDATA MSYS PAINT
//    "TOOL PATH" END-OF-PATH ...) are accepted silently; any other record is a ReaderWarning
//    naming its line.
//  - Errors: malformed number, wrong number of values, unknown UNITS/FEDRAT/MULTAX modifier, a
//    record name without its '/' (GOTO 1,2,3), the file ending inside a `$` continuation.
//
// G-code subset (read_gcode), Fanuc / Siemens dialect:
//  - Words: a letter and a decimal number (X10 is 10 mm: decimal-point programming), Siemens
//    `X=10` and extended addresses `A3=0.5`; comments `( ... )` and after `;`; `%` lines and O
//    program numbers skipped; N is kept as SourceBlock::block_number; a block starting with `/`
//    (block delete) is skipped with a warning. S words are accepted and ignored (D: cutter compensation, below); M2/M30
//    end the program (the rest of the file is not read); M98/M99 and G65 are subprogram calls
//    (below, "G-code programs"); other M codes are ignored. An address twice in one block is an
//    error.
//  - G0 G1 G2 G3 (modal; an axis word before any of them is an error), G17/G18/G19 planes
//    (arcs turn in (X,Y), (Z,X), (Y,Z); G3 is counter-clockwise seen from the plane normal +Z,
//    +Y, +X), G20/G21 inch/mm (lengths and F), G90/G91 absolute/incremental (X Y Z A B C),
//    G91.1 (default) / G90.1 arc centres I J K incremental from the start / absolute in program
//    coordinates, G93/G94 inverse-time (F in 1/min, needed in every G1/G2/G3 block, stored as
//    inverse_time_feed_per_s; an arc tessellated into n segments gives each n*F) / per-minute
//    feed, F modal under G94 and > 0.
//  - Arcs: I J K (centre) or R (R < 0: the arc of more than 180 deg); I J K with the end point
//    equal to the start: a full circle (R cannot program one); motion along the plane normal
//    makes a helix. Tessellated into MotionKind::arc points with chord error (in the arc plane)
//    <= ReaderOptions::arc_chord_tolerance_m; the last point is the programmed end point. Start
//    and end radii may differ by max(arc_radius_tolerance_mm (G21) or _inch (G20),
//    arc_radius_relative_tolerance * r) (LinuxCNC's defaults: 0.02 sqrt 2 mm, 0.002 sqrt 2
//    inch, 0.1 %): the centre is then moved to the nearest point of the perpendicular bisector
//    of start and end (a circle through both, as the control corrects it); beyond, an error
//    giving both radii, the difference and the tolerance. An R smaller than half the chord by
//    at most the same tolerance makes a half circle. An arc as the very first motion (unknown
//    start) is an error. G2/G3 cannot change the tool orientation.
//  - Coordinate systems (as on a Fanuc control). Outside tool-centre-point mode X Y Z are work
//    coordinates: the machine axis positions are
//        machine = work offset + G52 + G92 + G68 rotation(program) + (0, 0, H length under G43),
//    and the pose comes from them through ReaderOptions::axis_words_to_pose (the machine's
//    direct kinematics: on a table machine the point turns with the table; the offset does not,
//    as on a control without dynamic fixture offset). Without a machine the machine axes are W
//    mapped through machine_axes_W / machine_zero_W_mm (identity) and the tip is the gauge point
//    less the H length along +Z. Under tool-centre-point mode X Y Z are the tip in the work
//    system fixed on the table: tip_W = work zero in W + G52 + G92 + rotation(program), where
//    the work zero in W = machine_axes_W * offset + machine_zero_W_mm. The work offsets
//    (ReaderOptions::work_offsets_mm) hold the machine axes X Y Z at which the spindle gauge
//    point is at each work zero (rotary axes at 0); with none given, G54 is the identity (X Y Z
//    are machine axes outside TCP and W coordinates under it, the meaning before offsets), so
//    programs and parts without a setup read as before.
//     - G54-G59, G54.1 P1-P48 select (initial: ReaderOptions::initial_work_offset); one not in
//       the table is an error naming what is set up. G10 L2 P1-6 / L20 P1-48 X Y Z set an offset
//       (machine axes, added under G91); G10 L1/L10 P<n> R<length> set a tool length.
//     - G43 H<n> (H: ReaderOptions::tool_length_mm, else default_tool_length_mm, else an error
//       naming the H; G43 without H: the tool in the spindle; H0: no length); an H alone changes
//       the length under G43; G49 cancels G43 / G43.4 / G43.5.
//     - G53 (one block, G0/G1): X Y Z are machine axis positions. G28 / G30: a rapid to the
//       intermediate point (the named axes, in program coordinates, G90/G91), then the named
//       axes (all without any) to ReaderOptions::g28_reference_mm / g30_reference_mm (machine
//       axes). Before all three axes are known (the usual `G28 G91 Z0` first), G28 and G53 only
//       record the named axes: the first point comes once all three are known. Both are errors
//       under tool-centre-point mode. Rotary words in G28/G30 (`G28 X0. Y0. A0.`) move those
//       axes to the word (the intermediate position), then to ReaderOptions::rotary_reference_deg.
//     - G52 X Y Z: local zero (named axes; G52 X0 Y0 Z0 cancels). G92 X Y Z: the current
//       position becomes the given coordinates; G92.1 cancels. G68 X Y R: rotation by R deg about
//       (X, Y) (the plane's two axes; omitted: the current position) in the current plane,
//       applied to absolute and incremental targets and arcs; G69 cancels.
//     - Changing offset, G52/G92, G43/G49 or G68 does not move the machine: an axis not named in
//       the next motion stays where it is. Leaving tool-centre-point mode (G49, TRAFOOF), the
//       machine axes are where the last tip and rotary words put them
//       (ReaderOptions::tip_to_axis_words: the `G49` / `G28 G91 Z0.` a 5-axis post writes at
//       the end retracts from there); switching into it, or without that callback, keeps the
//       program numbers.
//  - Before the first motion, an axis not yet programmed is taken at the G28 reference point
//    (the machine's home, where a tool change leaves the axes) when work offsets are set up and
//    outside tool-centre-point mode (a post that positions X Y before its G43 H Z move), else at
//    the program's 0; with a warning.
//  - Canned cycles G73 G74 G76 G81 G82 G83 G84 G85 G86 G87 G88 G89 (modal until G80 or another
//    motion G-code; after G80 the G0 .. G3 in force before the cycle is back, as on a Fanuc,
//    where the cycles are a modal group of their own; X Y the hole, Z the bottom, R the R level,
//    Q the peck, P the dwell at the bottom in ms (PathPoint::dwell_s), K or
//    L repeats, G98 return to the initial level (the drilling axis when the cycle started, or R
//    if higher) / G99 to R). Incremental: R from the initial level, Z from R, X Y per repeat.
//    Each hole: up to R first where below it, rapid in the plane to the hole, rapid to R; G81
//    G82 G86 feed to the bottom; G85 G89 G84 G74 feed to the bottom and back to R; G83 pecks of
//    Q, each followed by a rapid to R and a rapid back to ReaderOptions::peck_clearance_mm
//    above the last depth; G73 pecks of Q, each followed by a rapid back-off of
//    peck_retract_mm; G76 (Fanuc fine boring) feeds to the bottom, shifts by Q along
//    ReaderOptions::fine_boring_shift_direction, leaves in rapid and shifts back; G88 (boring,
//    manual retract) feeds to the bottom, and the control stops (dwell P, spindle stop) for the
//    operator to take the tool out by hand: taken as a rapid straight out along the drilling
//    axis to R (an assumption, with a warning), after which cycle start gives the return; then
//    the rapid out. G87 (Fanuc back boring; R below the part, Z above R): up to the initial
//    level where below it, rapid in the plane to the hole, shift by Q (spindle oriented), rapid
//    down to R, shift back, feed up to Z, shift, rapid up to the initial level, shift back; it
//    always returns to the initial level (G99 is not used with G87 on a Fanuc: a warning). The
//    G76 / G87 shift may also be given as I J under G17 (Fanuc with I J shifts, Haas): the
//    vector (I, J) in the plane, modal in the cycle like Q; Q and I J together are an error.
//    LinuxCNC does not implement G87 / G88 (and the reader has no dialect switch): Fanuc's
//    motion is the one read. Drilling axis: the plane normal. Every point of a cycle is an exact
//    stop (corner_tolerance_m 0).
//  - Path control into PathPoint::corner_tolerance_m (modal): G61 / G61.1 exact stop 0; G9 exact
//    stop at the end of its block; G64 P<tol> (program units) its tolerance; G64 without P NaN
//    (the control's own blending: the part file or command line decides); G5.1 Q1 (R is a
//    smoothing level, not a length), G05 P10000 and G187 P1-3 without E:
//    ReaderOptions::contouring_tolerance_m; G187 E<tol> that tolerance; G5.1 Q0, G05 P0, G187
//    alone: NaN. Points inside a block (arc chords, rotary steps) carry NaN where the mode is an
//    exact stop (they are no corners of the program).
//  - Tools: T<n> preselects, M6 puts it in the spindle (in either order in one block; M6 with
//    no T before is an error); PathPoint::tool_number from then on (-1 before), and its length
//    (PathPoint::tool_length_m) is the tool whose tip the machine axes place: after `T2 M6 G43
//    H2` machine Z = offset + H2 + Z, and the tip of T2 (as long as H2 says) is at Z; under
//    G43.4 the programmed tip is the new tool's. An H that is not the tool's own length leaves
//    the tip off by the difference, as on the machine.
//  - Tool-centre-point programming (X Y Z are the tool tip in the work system): Fanuc G43.4
//    (tool axis from rotary words A B C through ReaderOptions::rotary_words_to_tool_axis),
//    G43.5 (tool vector I J K on G0/G1 blocks), G49 cancels; Siemens TRAORI (tool vector A3= B3=
//    C3=, or rotary words through rotary_words_to_tool_axis), TRAFOOF cancels. In a tool vector,
//    a component left out of a block that gives another is 0; a block giving none keeps the
//    current axis. Rotary words without the callback are an error that says a machine is needed.
//  - Outside tool-centre-point mode: with ReaderOptions::axis_words_to_pose every point (arc
//    points too) is the pose of the modal machine axes X Y Z [A B C] (above); without it, the
//    axis is +Z (a 3-axis program); a rotary word, or a motion after a tilted TCP axis, is then
//    an error that says a machine is needed.
//  - Rotary words through a machine (axis words, or G43.4 / TRAORI A B C): each point carries the
//    words in force (PathPoint::rotary_words_deg; a tool vector, G43.5 I J K, makes them
//    unknown), and a point whose words differ from the
//    previous one's is kept even where its pose is the same (C0 -> C360 is a real turn). A G0/G1
//    block that turns a word by 180 deg or more is split into equal steps of at most 90 deg in
//    axis space (as the NC interpolates the axes), since the chain follows poses and the inverse
//    kinematics takes the nearest solution from one pose to the next.
//  - Cutter radius compensation (cutter_compensation.hpp has the geometry and LinuxCNC's rules):
//    G41 (tool left of the contour) / G42 (right) with D<n>: the radius is
//    ReaderOptions::cutter_radius_mm[n] (else default_cutter_radius_mm, else an error naming D);
//    without D the last D given, else the tool in the spindle; D0: radius 0 (no offset).
//    LinuxCNC's G41.1 / G42.1 D<diameter> give the diameter in the block. G40 cancels. G17
//    only (G18 / G19, tool-centre-point mode and G93 are errors), XY lines and arcs offset to
//    the side, concave corners at the offsets' intersection, convex ones rolled about the
//    corner (arcs of the tool radius), moves along Z only at the offset position; the first
//    move in the plane (the entry) must be a line longer than the radius and ends where it is
//    tangent to the tool circle about its programmed end; G40 ends the last element at its
//    offset end and the position is the tool's from there (the next move in the plane must be a
//    line). Errors: an inside arc not larger than the tool, a gouge (an offset element running
//    backwards, a concave corner the tool does not fit), and under compensation a plane, unit,
//    work offset, G52 / G92 / G10, G68 / G69, G43 / G49 / H, G53, G28 / G30, canned cycle,
//    rotary or tool vector word, or a new D. A G41 / G42 still on at the end of the program is
//    ended as by G40 (with a warning).
//  - Dwells (PathPoint::dwell_s, on the point the tool is at; under G41 / G42 a warning, not
//    timed): G4 X<seconds> or G4 P<milliseconds> (Fanuc; LinuxCNC's P in seconds is not read:
//    P500 is 0.5 s); the canned cycles' P (ms) at the hole bottom (G74 G76 G82 G84 G87 G88
//    G89).
//  - Accepted and ignored: G15 G50, G80 (ends a cycle), G8 P1/P0
//    (look-ahead), the Q of G64 (LinuxCNC's folding of collinear points).
//    Errors naming the word: G68.1 3-D rotation, G51 scaling, G16
//    polar, any other G-code, and words outside this list (U V W, Siemens keywords
//    other than TRAORI/TRAFOOF); P Q L E where their G-code does not use them.
//
// Siemens Sinumerik 840D subset (read_siemens; toolpath/src/siemens_reader.cpp): programs as NX,
// hyperMILL and PowerMill posts write them for the 840D. One pass runs the program as the
// control does (language and blocks together, each block in the order it is reached). The
// common rules above apply (errors "file:line:column: 'word': ...", limits, UTF-8).
//  - Text: `;` starts a comment; `%_N_NAME_MPF` headers are skipped; a block starting with `/`
//    is skipped with a warning; N123 and :123 are block numbers (SourceBlock::block_number),
//    `LABEL:` a jump label. Words: a letter and a number (X10.5, G642), `ADDRESS=expression`
//    (X=R1+5, CR=10, A3=0.6, I1=AC(5)), keywords (TRAORI, SOFT), calls KEYWORD(a, , c).
//  - Language: R parameters R0..R99999 (global, start at 0), `DEF INT|REAL|BOOL|CHAR name[=v],
//    ...` (local to the program level; STRING accepted and not kept; arrays are errors),
//    assignments in order within a block (R1=4 R2=R1*2 gives 8), expressions with + - * /
//    DIV MOD, == <> < > <= >=, NOT AND OR XOR, parentheses, SIN COS TAN ASIN ACOS ATAN2 (deg)
//    SQRT ABS POT TRUNC ROUND ROUNDUP LN EXP MINVAL MAXVAL, TRUE FALSE and CYCLE832's
//    constants (_OFF 0, _FINISH 1, _SEMIFIN 2, _ROUGH 3, _PRECISION 4, _ORI_FINISH 11,
//    _ORI_SEMIFIN 12, _ORI_ROUGH 13). Control flow: IF c GOTOF/GOTOB/GOTO label (or N number),
//    IF c ... [ELSE ...] ENDIF, WHILE c ... ENDWHILE, FOR v = a TO b ... ENDFOR, REPEAT ...
//    UNTIL c, LOOP ... ENDLOOP, GOTOF / GOTOB / GOTO. Subprograms: `L<n> [P<k>]` and a bare
//    name (MYSUB) call NAME.SPF / name.spf in ReaderOptions::subprogram_folder (P: k runs), M17
//    or RET return, the end of the file returns; PROC lines are skipped (no parameters). MSG(...)
//    and STOPRE do nothing. System variables ($...) are errors. Limits:
//    ReaderOptions::max_executed_blocks, max_call_depth as for G-code.
//  - Motion: G0 G1 G2 G3 CIP CT (modal), G17 G18 G19, G70/G700 inch, G71/G710 mm, G90/G91 and
//    per word X=AC(..) / X=IC(..), G93/G94 (G95 G96: errors), F, G4 F<seconds> / G4 S<spindle revolutions> at the last S
//    word's speed (none before: an error) -> PathPoint::dwell_s.
//    G2/G3: I J K incremental from the start (I=AC(..): absolute), or CR=r (r < 0: more than
//    180 deg); end radius tolerance and helix as for G-code. CIP X Y Z I1= J1= K1=: the circle
//    through start, intermediate point (absolute under G90, from the start under G91 or IC)
//    and end, in any plane. CT X Y Z: the arc leaving the start along the previous motion's
//    tangent. Arcs are tessellated in program coordinates and each point goes through the
//    frames, so MIRROR turns G2 into G3 as on the control. AR= TURN= AP= RP=: errors.
//  - Frames (program point p to the machine): programmable frame P (TRANS X Y Z, ROT X Y Z as
//    RPY: about Z, then the new Y, then the new X, the 840D default; ROT RPL= about the plane's
//    normal; MIRROR X0 (the named axes change sign); each absolute instruction replaces the
//    whole programmable frame (TRANS or ROT alone: none); ATRANS AROT AMIRROR add in the current
//    frame, P = P o step); the swivel S of CYCLE800; the settable offset G54..G57, G505..G599
//    from ReaderOptions::work_offsets_mm (G500: none; without a table G54 is the identity as for
//    G-code). Outside TRAORI and without a swivel X Y Z give the machine axes:
//        machine = offset + (0, 0, tool length under D) + P(p), the pose through
//    ReaderOptions::axis_words_to_pose (as G-code with G43); under TRAORI or a swivel the tip in
//    W is the work zero in W + S(P(p)). A frame, offset, tool or mode change does not move the
//    machine (an axis not programmed next stays where it is). SUPA / G53 / G153: X Y Z in that
//    block are machine axes (G0/G1, outside TRAORI and the swivel). SCALE: error.
//  - CYCLE800(_FR, _TC, _ST, _MODE, _X0, _Y0, _Z0, _A, _B, _C, _X1, _Y1, _Z1, _DIR, ...): axis by
//    axis only (_MODE bits 6-7 = 0; bits 0-1, 2-3, 4-5 the axes of the 1st, 2nd, 3rd rotation:
//    1 X, 2 Y, 3 Z, so 57 = X then Y then Z, 27 = Z, Y, X), each about the frame's own, turned
//    axis: S(q) = (_X0, _Y0, _Z0) + R ((_X1, _Y1, _Z1) + q), R = R1(_A) R2(_B) R3(_C); _ST units
//    digit 1 adds to the swivel in force, else replaces it; CYCLE800() or zero angles and
//    offsets: no swivel. The tool axis becomes R z. Not emulated: the retraction _FR and the
//    swivel's own motion (the next motion turns the axes), _DIR (the chain's inverse kinematics
//    picks the branch nearest the previous pose), solid-angle / projection / direct modes (errors).
//  - Tools: T<n> or T="name" selects (a name: PathPoint::tool_number -1, the part file's tool),
//    M6 loads it and activates D1; D<n> (D0: none) switches the length
//    (ReaderOptions::tool_length_mm by T number, else default_tool_length_mm; a length needed
//    and unknown is an error naming T and D).
//  - Cutter radius compensation G41 / G42 (G40 cancels), as for G-code above (G17, the same
//    offset geometry and errors, CIP / CT, frame instructions, CYCLE800, TRAORI, T / D / M6
//    changes refused under it), with the radius of the active tool (ReaderOptions::
//    cutter_radius_mm by T number, else default_cutter_radius_mm; D0: none) and the 840D's
//    default approach NORM: the entry move goes straight to the first element's offset start.
//    The points go through the frames, so under MIRROR the tool stays on the mirrored side.
//  - 5-axis: TRAORI / TRAORI(n) on, TRAFOOF off; under TRAORI X Y Z are the tip and the tool
//    axis is A3 B3 C3 (ORIWKS: in the workpiece frame, turned by the frames' rotation), or the
//    rotary words A B C through ReaderOptions::rotary_words_to_tool_axis; outside TRAORI rotary
//    words are machine axes (axis_words_to_pose) and are errors under a swivel. ORIWKS ORIMKS
//    ORIAXES ORIVECT and the like are accepted: the chain interpolates the tool axis between
//    points its own way. Turns of 180 deg or more are split as for G-code.
//  - NC modes into the path points: G60 (modal) and G9 (one block): exact stop (0); G64: NaN
//    (no tolerance given); G641 ADIS=d: d (the blend stays within d of the corner; ADIS=0 as
//    G64); G642 / G643 / G644 / G645: CTOL= where given, else CYCLE832's tolerance, else
//    ReaderOptions::contouring_tolerance_m (the machine data's). SOFT: JerkMode::soft; BRISK and
//    DRIVE: brisk. FFWON / FFWOF: FeedforwardMode::on / off. COMPCAD COMPCURV COMPON: the
//    compressor on within CYCLE832's tolerance (else CTOL, else contouring_tolerance_m); COMPOF:
//    0. CYCLE832(tol, type, ...) with type's units digit not 0 (and tol > 0): G642 within tol,
//    COMPCAD within tol, SOFT, FFWON (the settings the standard cycle makes); type 0 or
//    CYCLE832(): G64, COMPOF, the tolerance forgotten (SOFT / BRISK and FFWON / FFWOF stay).
//    DYNNORM DYNROUGH DYNSEMIFIN DYNFINISH (dynamic response groups: machine data) are accepted
//    and not modelled. Points inside a block (arc chords, rotary steps) carry no corner mode.
//  - Drilling cycles along the plane's axis (G17: Z) at the tool's position, in program
//    coordinates through the frames, each level an exact stop (corner_tolerance_m 0):
//    CYCLE81(RTP, RFP, SDIS, DP, DPR) and CYCLE82(..., DTB): G0 to RFP + SDIS, G1 to the depth
//    (DPR when given and not 0: RFP - |DPR|, else DP), G0 to RTP. CYCLE83(RTP, RFP, SDIS, DP,
//    DPR, FDEP, FDPR, DAM, DTB, DTS, FRF, VARI, _AXN, _MDEP, _VRT, _DTD, _DIS1): the first stroke
//    to FDPR below RFP (else FDEP) at F * FRF (0: F), each next one DAM shorter, not shorter
//    than DAM or _MDEP; VARI 0 (chip breaking): after each stroke G1 back _VRT (0: 1 mm) at F;
//    VARI 1 (swarf removal): G0 to RFP + SDIS and G0 back to the anticipation distance above
//    the depth reached (_DIS1, else 0.6 mm for holes up to 30 mm, depth / 50 up to 7 mm
//    beyond); G0 to RTP. Dwell at the depth (PathPoint::dwell_s): CYCLE82 DTB, CYCLE83 _DTD
//    (0: DTB), in seconds (< 0: spindle revolutions); DTB at CYCLE83's intermediate strokes and
//    DTS are not timed. MCALL CYCLE8x(...) calls the
//    cycle after every following block with X Y Z words until MCALL alone. Errors at the
//    cycle: no depth, the depth not below RFP, RTP below RFP, DAM < 0 (degression factor),
//    _AXN not the plane's axis, no F, under G41 / G42 or G93, more points than
//    ReaderOptions::max_points_per_block. Other cycles (CYCLE84 ...) are errors.
//
// G-code programs (read_gcode; toolpath/src/gcode_program.cpp): the programming language of
// Fanuc Custom Macro B and LinuxCNC runs first, and the block interpreter above reads the blocks
// it gives, in the order the control runs them, with every parameter and expression replaced by
// its number (SourceBlock::line and ::text stay the source line as written; a block run several
// times gives a SourceBlock each time, all naming that line). A line with no '#', '[', '<', O
// word, keyword of two or more letters, M98/M99 or G65-G67 goes through untouched.
//  - Parameters: #1-#33 are local to a call level (G65 and o-call give the callee its own;
//    M98 shares its caller's), #34-#999 common to all (Fanuc #100-#199, #500-#999; nothing is
//    kept from one reading to the next); all start vacant. #0 is always vacant. #1000 and above
//    are control system variables, which are not simulated (an error), except that writing
//    #3000 (Fanuc alarm) stops with an error quoting the value and the block's comment.
//    LinuxCNC named parameters #<name> are local to the call level, #<_name> global; names
//    ignore case and blanks; reading one never set is an error (EXISTS[#<name>] tests it).
//    Indirection: #[expression], ##n. A parameter number must be an integer (within 1e-4).
//  - Vacant (Fanuc): a word whose value is vacant is left out of its block (G90 X#1 with #1
//    vacant is G90); [#1] and -#1 stay vacant; any arithmetic or function reads vacant as 0; EQ
//    and NE tell vacant from 0 (#1 EQ #0 is true only when #1 is vacant), GT GE LT LE read it as
//    0. (LinuxCNC's numbered parameters start at 0 instead: such a program that reads one never
//    set gets the word left out here.)
//  - Assignments: `#i = expression`, several on one line; as in LinuxCNC, the values set on a
//    line take effect after the whole line is read (#1=5 #2=#1 gives #2 the old #1).
//  - Values in words: any address takes a number, #..., [expression] or a function (LinuxCNC
//    X SIN[30]), with a sign: X#1, X-#1, X[#1+2], G#2, F#3, Siemens X=#1. A macro value of an
//    integer address (M T H D N L O, not G) is rounded to an integer as on Fanuc; others are
//    handed on at full precision (shortest decimal text that reads back the same double).
//  - Expressions in [ ]: numbers, parameters, unary - and +, binary ** (power), * / MOD, + -,
//    EQ NE GT GE LT LE (1 or 0), AND OR XOR (logical: non-zero is true), with LinuxCNC's
//    precedence: ** first, then * / MOD, then + -, then comparisons, then AND OR XOR, each
//    left to right (Fanuc puts AND with * and OR XOR with +: a Fanuc program that brackets its
//    conditions, [[#1 GT 0] AND [#2 LT 5]], reads the same). MOD as LinuxCNC: 0 <= a MOD b <
//    |b|. Functions, angles in degrees: SIN COS TAN ASIN ACOS, ATAN[y]/[x] (and ATAN[y,x]; in
//    (-180, 180]; ATAN[t] alone: one argument), SQRT ABS ROUND (half away from zero) FIX
//    (fraction dropped, as Fanuc: FIX[-1.2] = -1) FUP (away from zero: FUP[-1.2] = -2; LinuxCNC
//    rounds down and up, the same for positive numbers) LN EXP, EXISTS[#<name>]. Errors:
//    division or MOD by zero, SQRT of a negative number, LN of a number <= 0, ASIN/ACOS outside
//    [-1, 1], a result beyond a double.
//  - Fanuc control flow: `IF [cond] GOTO n`, `IF [cond] THEN #i = expression ...`, `GOTO n`
//    (n an expression; to the block N n of the program running, searched forward, then from the
//    program's start), `WHILE [cond] DO m` ... `END m` (m a loop number; `DO m` alone loops for
//    ever). Fanuc subprograms: `O<n>` ... `M99` in the same file, after the main program's M30 or
//    before the main program (the main flow steps over a program that ends with M99); `M98 P<n>
//    [L<k>]`, and the packed form M98 P<kkkknnnn> (k times program nnnn) where no program
//    numbered P exists; other words of an M98 block run before the call. `G65 P<n> [L<k>]`
//    with arguments A B C I J K D E F H M Q R S T U V W X Y Z into #1 #2 #3 #4 #5 #6 #7 #8 #9 #11
//    #13 #17-#26 (argument specification I); the other locals of the macro start vacant. M99
//    in the main program ends it (the control would start it again); a file whose only
//    program ends with M99 (no M2/M30 anywhere) runs that program once. Modal calls: `G66
//    P<n> [L<k>]` with G65's arguments calls the macro (k times, each from the arguments
//    again) after every following block that moves an axis (an axis word X Y Z A B C U V W;
//    not G4 dwells nor G10 / G52 / G92 settings, nor blocks without an axis word), returning to
//    the block after it (or its GOTO's target), until G67 (which cancels the last G66 given;
//    G66 blocks nest as a stack). The moves of the macro a modal call started do not call it
//    again; those of an M98 / G65 subprogram called under G66 do. An unknown program is an
//    error at the G66; a modal call beyond ReaderOptions::max_call_depth at the move word that
//    would make it. `G66.1 P<n> [L<k>]` (Fanuc "each block" call) calls the macro from its
//    own block (its arguments), then every following block with a word other than N calls
//    the macro instead of running, the block's words the arguments (A -> #1 ... Z -> #26 as
//    G65; G L O P words are an error there), returning to the next block (or its GOTO's
//    target), until G67; blocks with only N, assignments, comments, IF / WHILE, M98 / M99
//    blocks and G65 / G66 blocks are no calls. Not supported (errors): M99 P (return to a
//    block number).
//  - Subprograms in other files: a program number or o-word subroutine not in the file is
//    looked for in ReaderOptions::subprogram_folder (read_gcode: the program's folder): M98 /
//    G65 P1234 in O1234.nc, o1234.nc, 1234.nc, O1234.NC (O0012.nc for P12), which may hold the
//    O line or the body alone, up to its M99; o<name> call in name.ngc (LinuxCNC), which holds
//    o<name> sub ... endsub. Their blocks (SourceBlock::file) and errors name that file.
//  - LinuxCNC o-words (numbered o100 or named o<name>, any case): `sub` / `endsub [value]` /
//    `return [value]` (the value goes to #<_value>), `call [a1] [a2] ...` (at most 30 arguments
//    into #1..#30 of the callee), `if [c]` / `elseif [c]` / `else` / `endif`, `while [c]` /
//    `endwhile`, `do` / `while [c]`, `repeat [n]` / `endrepeat`, `break`, `continue`. The main
//    flow steps over a sub ... endsub definition, wherever it is in the file.
//  - Comments (...) and after ';' are never run (LinuxCNC (debug, ...) and (print, ...) are
//    ignored). A block-delete line ('/') is skipped whole, its assignments too.
//  - Limits and errors: from the program's first jump on, every block run counts towards
//    ReaderOptions::max_executed_blocks (default 10 million: a loop that never ends stops with
//    an error naming the block; a program that runs straight through is not limited) and
//    calls nest at most ReaderOptions::max_call_depth deep (default 64). Every error names the
//    file, line and column: an unknown parameter syntax, a named parameter not set, an undefined
//    block number, program or subroutine, a WHILE without its END (or END without its WHILE),
//    an o-word without its partner (if without endif, endwhile without while, sub without
//    endsub), the end of the file inside a subprogram (no M99 / endsub), a subprogram that runs
//    into the next program. An error of the block interpreter in a word made from an
//    expression names that word's source column and quotes the word with its value (X2000000).
//
// KUKA KRL subset (read_krl; toolpath/src/krl_reader.cpp), as robot CAM posts write programs:
//  - Lines; ';' starts a comment (so ;FOLD / ;ENDFOLD are comments), '&' lines (editor
//    attributes) are skipped; names ignore case. DEF name() starts the program, its END ends it
//    (a second DEF, a local subprogram, is not run). DEFDAT / ENDDAT, EXT, DECL of types other
//    than positions, WAIT, HALT, $OUT and other system variables are accepted and change nothing;
//    calls other than BAS are warnings (not simulated).
//  - Positions: aggregates {[E6POS: | POS: | FRAME:] X x, Y y, Z z, A a, B b, C c[, S s, T t,
//    E1 ..]}: X Y Z [mm] and A B C [deg] are the TCP frame in $BASE, with KUKA's ZYX Euler
//    angles (R = Rz(A) Ry(B) Rx(C)); S and T (the arm configuration) are read and not used
//    (the inverse kinematics chooses, next to the previous pose); components left out keep the
//    current position's. Axis positions {[E6AXIS: | AXIS:] A1 .. A6} [deg] (PTP only).
//    Variables: DECL E6POS / POS / FRAME / E6AXIS / AXIS name = {...}, in the program or in its
//    companion .dat file (the teach pendant's inline forms: PTP XP1), and name = {...}.
//  - Frames: $BASE = {FRAME: ...} (the base in $WORLD), BASE_DATA[n] = {...} and $BASE =
//    BASE_DATA[n] or BAS(#BASE, n) (n = 0: $WORLD); $TOOL and TOOL_DATA / BAS(#TOOL, n) likewise.
//    $WORLD is placed in W by ReaderOptions::krl_world_in_W (the app: the robot's base). A
//    BASE_DATA / TOOL_DATA used but not set in the program is an error (the controller's
//    $config.dat is not part of the program). $TOOL does not change the canonical path: the
//    TCP is the tool tip; the machine file and the part's tool length say where it is.
//  - Tool axis: the TCP frame's x axis is the tool direction (KUKA's $TOOL_DIRECTION #X, from
//    the spindle into the work), so axis_W = -x of the TCP frame. The rotation about it (the
//    sixth degree of freedom) is not part of the canonical path: the robot's redundancy is the
//    inverse kinematics' to choose.
//  - Motions: LIN target (MotionKind::linear); CIRC auxiliary, target: the circle through the
//    start, the auxiliary and the target point, tessellated as G2/G3 (arc_chord_tolerance_m),
//    the orientation turned from the start's to the target's in proportion to the angle
//    ($ORI_TYPE #VAR; the auxiliary point's orientation is not used, as on the control); PTP
//    target (Cartesian, or axis values through ReaderOptions::robot_joints_to_pose) is a rapid
//    to that pose (the robot's joint-interpolated route differs: it is outside the cut).
//  - Feed: $VEL.CP [m/s] (or BAS(#VEL_CP, v)) for LIN and CIRC; LIN / CIRC before any is an
//    error. Approximation: C_DIS blends the corner within $APO.CDIS [mm]
//    (PathPoint::corner_tolerance_m); C_VEL, C_ORI, C_PTP blend by a criterion that is not a
//    distance (NaN: the part file or the command line decides); none: exact stop (0).
//  - Errors: LIN_REL / PTP_REL / CIRC_REL, spline motions (SPLINE, SLIN, SCIRC, SPTP), CIRC with
//    CA, control flow (IF, FOR, WHILE, LOOP, GOTO, SWITCH), the geometric operator ':', an
//    unknown component, an undeclared variable, a malformed number, CIRC through three points on
//    one line, a first motion that leaves components out.
#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <limits>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace vmsim::toolpath {

/// One source block (a line of G-code, or an APT record with its `$` continuations). Only the
/// blocks that program a motion are listed.
struct SourceBlock {
  std::string file;
  int line = 0;          ///< first line of the block, 1-based
  long block_number = -1;  ///< G-code N number, -1 where none
  std::string text;      ///< the block as written (continuations joined)
};

enum class MotionKind {
  rapid,   ///< G0 / APT RAPID: positioning, not part of the cut
  linear,  ///< G1 / APT GOTO
  arc,     ///< a point on a G2/G3 arc (tessellated; see ReaderOptions::arc_chord_tolerance_m)
};

/// Jerk limitation asked by the program: Siemens BRISK (acceleration steps: the planner's second
/// order) or SOFT (jerk limited: third order).
enum class JerkMode { unspecified, brisk, soft };
/// Velocity feedforward asked by the program (Siemens FFWON / FFWOF).
enum class FeedforwardMode { unspecified, on, off };

/// One point of the tool path: the pose reached at the end of a motion.
struct PathPoint {
  Eigen::Vector3d tip_W_m = Eigen::Vector3d::Zero();        ///< tool tip (APT CL point)
  Eigen::Vector3d axis_W = Eigen::Vector3d::UnitZ();        ///< unit tool axis, tip -> spindle
  MotionKind kind = MotionKind::linear;
  /// Programmed feed for the motion that ends here [m/s]; 0 for rapids and under G93.
  double feed_m_per_s = 0.0;
  /// G93 inverse-time feed [1/s] for this motion, where programmed (feed_m_per_s is then 0).
  double inverse_time_feed_per_s = 0.0;
  int block = -1;  ///< index into Toolpath::blocks of the block that programmed this motion
  /// The rotary axis words A B C [deg] in force here where the program gives machine axes
  /// (G-code axis words through ReaderOptions::axis_words_to_pose, or G43.4 / TRAORI rotary
  /// words); NaN where not programmed. Two points with the same pose but different words are
  /// different machine positions (a 360 deg turn of C), never merged.
  static constexpr double kNotProgrammed = std::numeric_limits<double>::quiet_NaN();
  std::array<double, 3> rotary_words_deg = {kNotProgrammed, kNotProgrammed, kNotProgrammed};
  /// The tool (T number, made active by M6) in the spindle for this motion; -1 where the program
  /// selects none (the part file's tool is meant).
  int tool_number = -1;
  /// The length of that tool from the spindle gauge point to its tip [m]
  /// (ReaderOptions::tool_length_mm by T number, else default_tool_length_mm; NaN where the
  /// reader has neither): the direct kinematics of the motion that ends here take it.
  double tool_length_m = kNotProgrammed;
  /// What the program asks at the corner where this motion ends [m]: 0 = exact stop (G61, G9),
  /// > 0 = blending within this tolerance (G64 P, high-precision contouring G5.1 / G05 P10000 /
  /// G187 with its tolerance); NaN where the program says nothing (the part file or the command
  /// line decides).
  double corner_tolerance_m = kNotProgrammed;
  /// NC modes the program asks for where this motion ends (Siemens SOFT/BRISK, FFWON/FFWOF,
  /// COMPCAD; Heidenhain's jerk filter, ...); "unspecified" / NaN where the program says nothing
  /// (the part file or the command line decides).
  JerkMode jerk_mode = JerkMode::unspecified;
  FeedforwardMode feedforward = FeedforwardMode::unspecified;
  /// Compressor (Siemens COMPCAD / COMPCURV / COMPON): short-segment polylines smoothed within
  /// this tolerance [m]; 0 = compressor off (COMPOF), NaN = not programmed.
  double compressor_tolerance_m = kNotProgrammed;
  /// Dwell [s] after the motion that ends here (G4, a drilling cycle's dwell at the bottom, TNC
  /// CYCL DEF 9): the tool stops here and stays at rest that long; 0 = none. Several dwells in a
  /// row add up.
  double dwell_s = 0.0;
};

/// A warning that names where it comes from (an unknown APT record, an ignored G-code word).
struct ReaderWarning {
  std::string file;
  int line = 0;
  std::string message;
};

/// An axis-parallel box in W [m].
struct BoxW {
  Eigen::Vector3d min_W_m = Eigen::Vector3d::Zero();
  Eigen::Vector3d max_W_m = Eigen::Vector3d::Zero();
};

struct Toolpath {
  /// The first point is the start pose (APT FROM, or the first programmed position).
  std::vector<PathPoint> points;
  std::vector<SourceBlock> blocks;
  std::vector<ReaderWarning> warnings;
  /// Tool from APT CUTTER where given: diameter and corner radius [m].
  std::optional<double> cutter_diameter_m;
  std::optional<double> cutter_corner_radius_m;
  /// The stock the program declares (Heidenhain BLK FORM 0.1 / 0.2), in W; simulate-part takes it
  /// where the part file gives no stock.
  std::optional<BoxW> stock_box;
};

/// Machine axis words (G-code X Y Z A B C without tool-centre-point programming) to a pose in
/// the workpiece frame. Given by the caller that knows the machine (the direct kinematics);
/// keys are axis letters, values in mm and deg as written (after G20 inch conversion).
struct AxisWordPose {
  Eigen::Vector3d tip_W_m;
  Eigen::Vector3d axis_W;
};
using AxisWordsToPose = std::function<AxisWordPose(const std::vector<std::pair<char, double>>&)>;

/// A tool pose in W (tip [m], unit axis) and the rotary axis words in force (A B C [deg]) to
/// the linear machine axis words X Y Z [mm] that put the tip there (the machine's inverse
/// kinematics with those rotary axes); std::nullopt where none does.
using TipToAxisWords = std::function<std::optional<Eigen::Vector3d>(
    const Eigen::Vector3d& tip_W_m, const Eigen::Vector3d& axis_W, const std::vector<std::pair<char, double>>&)>;

/// Rotary axis words (A B C in deg, under G43.4 or TRAORI) to a unit tool axis in W.
using RotaryWordsToToolAxis =
    std::function<Eigen::Vector3d(const std::vector<std::pair<char, double>>&)>;

struct ReaderOptions {
  /// Largest distance between a G2/G3 arc and the chords it is tessellated into [m].
  double arc_chord_tolerance_m = 0.1e-6;
  /// G2/G3: the largest difference between the start and the end radius accepted, as on the
  /// control: the larger of an absolute tolerance (in the program's unit: mm under G21, inch
  /// under G20) and a relative one (times the radius). The defaults are LinuxCNC's: 0.02 sqrt 2
  /// mm / 0.002 sqrt 2 inch (an arc whose end points and centre were rounded to 0.01 mm or
  /// 0.001 inch) and 0.1 %. Within it the centre is moved onto the perpendicular bisector of
  /// start and end (as Fanuc and Beckhoff controls correct it); beyond it, an error.
  double arc_radius_tolerance_mm = 0.02 * 1.4142135623730951;
  double arc_radius_tolerance_inch = 0.002 * 1.4142135623730951;
  double arc_radius_relative_tolerance = 1e-3;

  /// Work offsets (G54-G59, G54.1 P1-P48): for each, the machine axis positions X Y Z [mm] at
  /// which the spindle gauge point (tool length 0) is at the work zero with the rotary axes at
  /// 0 (what the control's offset table holds). Keys "G54" ... "G59", "G54.1 P1" ...
  /// "G54.1 P48". Empty: G54 is the identity (X Y Z outside tool-centre-point mode are machine
  /// axis positions, under it W coordinates: the meaning before work offsets existed) and every
  /// other offset is an error.
  std::map<std::string, Eigen::Vector3d> work_offsets_mm;
  /// The offset in force at the start of the program (a key of work_offsets_mm, or "G54").
  std::string initial_work_offset = "G54";
  /// Machine axis positions to W with the rotary axes at 0, for the spindle gauge point:
  /// p_W_mm = machine_axes_W * axes_mm + machine_zero_W_mm (identity without a machine). Gives
  /// where a work zero lies in W, the origin of tool-centre-point programs.
  Eigen::Matrix3d machine_axes_W = Eigen::Matrix3d::Identity();
  Eigen::Vector3d machine_zero_W_mm = Eigen::Vector3d::Zero();
  /// G28 / G30 reference points in machine axis positions X Y Z [mm].
  Eigen::Vector3d g28_reference_mm = Eigen::Vector3d::Zero();
  Eigen::Vector3d g30_reference_mm = Eigen::Vector3d::Zero();
  /// Where G28 / G30 send the rotary axes A B C named in the block [deg] (the machine's home;
  /// Mastercam's `G28 X0. Y0. A0.` on a 4- and 5-axis machine).
  std::array<double, 3> rotary_reference_deg = {0.0, 0.0, 0.0};
  /// Tool lengths by H (and T) number [mm], for G43 H<n>; a number not in the table takes
  /// default_tool_length_mm where given, else is an error. By T number it is also the length of
  /// the tool in the spindle (PathPoint::tool_length_m). axis_words_to_pose and
  /// tip_to_axis_words place a tool default_tool_length_mm long (the caller's); where the tool
  /// in the spindle is longer or shorter, the readers move the tip along the tool axis by the
  /// difference (the same machine axes, another tool: tip = gauge point - length x axis).
  std::map<int, double> tool_length_mm;
  std::optional<double> default_tool_length_mm;
  /// Cutter radii by D number [mm] (the tool table's diameter / 2), for G41 / G42 D<n>; a
  /// number not in the table takes default_cutter_radius_mm where given, else is an error.
  std::map<int, double> cutter_radius_mm;
  std::optional<double> default_cutter_radius_mm;
  /// Canned cycles: G83 stops this far [mm] above the previous peck's depth before feeding on;
  /// G73 backs off this far [mm] after each peck (Fanuc parameters 5115 and 5114, machine
  /// dependent).
  double peck_clearance_mm = 0.1;
  double peck_retract_mm = 0.1;
  /// G76 fine boring: the direction of the shift Q at the bottom, in the plane's axes (u, v) =
  /// (X, Y) under G17 (Fanuc parameter 5101 RD1/RD2, set on the machine); made unit.
  Eigen::Vector2d fine_boring_shift_direction = Eigen::Vector2d::UnitX();
  /// The corner tolerance [m] of high-precision contouring where the program gives none
  /// (G5.1 Q1, G05 P10000, G187 without E): an assumption, 10 um.
  double contouring_tolerance_m = 0.01e-3;
  /// Needed only for files that program machine axes with rotary words outside tool-centre-point
  /// mode; without it such a file is an error that says so.
  AxisWordsToPose axis_words_to_pose;
  /// Needed only for G43.4 / TRAORI blocks that give A B C rather than a tool vector.
  RotaryWordsToToolAxis rotary_words_to_tool_axis;
  /// Leaving tool-centre-point mode (G49 after G43.4 / G43.5, TRAFOOF): where the machine axes
  /// are (the control knows them; the program's X Y Z were the tip). Without it, or where it
  /// gives none, the program numbers are kept across the switch (an axis not named next is then
  /// taken at its tip coordinate, which a machine with rotary axes turned does not share).
  TipToAxisWords tip_to_axis_words;
  /// Expansion limits, checked before the points are made: the points one block may expand to
  /// (an arc's tessellation, a long rotary turn's steps), and the points of the whole path. A
  /// path point costs about 100 bytes in the reader and about 1 kB further down the chain (axis
  /// positions and their derivatives, the planner's grid, set points): 2 million points is about
  /// 2 GB, as much as a simulation on an ordinary workstation should take.
  std::size_t max_points_per_block = 1'000'000;
  std::size_t max_path_points = 2'000'000;
  /// G-code programs (parameters, loops, subprograms): the blocks the program may run from its
  /// first jump (GOTO, loop, call) on, each run of a block counted (a loop that never ends stops
  /// here with an error naming the block; a program that never jumps is not limited), and the
  /// depth of nested calls (M98, G65, o-word call).
  std::size_t max_executed_blocks = 10'000'000;
  std::size_t max_call_depth = 64;
  /// Where a G-code program's subprograms that are not in its own file are looked for (M98 /
  /// G65 P1234: O1234.nc, o1234.nc, 1234.nc; o<name> call: name.ngc). Empty: nowhere;
  /// read_gcode and read_toolpath give the program file's folder when this is empty.
  std::string subprogram_folder;
  /// KUKA KRL programs (read_krl): the pose of the robot's $WORLD frame in W (4x4 homogeneous,
  /// translation in m); identity: KRL's $WORLD is W.
  Eigen::Matrix4d krl_world_in_W = Eigen::Matrix4d::Identity();
  /// KUKA KRL PTP with axis values {A1 .. A6} [deg]: the tool pose they give (the machine's
  /// direct kinematics). Without it such a PTP is an error that says a machine is needed.
  std::function<AxisWordPose(const std::vector<double>&)> robot_joints_to_pose;
};

/// Reads an APT/CL file (subset above). Throws vmsim::InputError naming the file, line, column
/// and word, also when the file cannot be read or programs no motion.
Toolpath read_apt(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_apt(const std::string& text, const std::string& file_name_for_messages,
                   const ReaderOptions& options = {});

/// Reads an ISO G-code file (Fanuc / Siemens dialect subset above). Throws vmsim::InputError
/// naming the file, line, column and word; also when arc_chord_tolerance_m is not positive.
Toolpath read_gcode(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_gcode(const std::string& text, const std::string& file_name_for_messages,
                     const ReaderOptions& options = {});

/// Reads a Siemens Sinumerik 840D program (subset above, "Siemens 840D"). Throws
/// vmsim::InputError naming the file, line, column and word. Subprograms (L<n>, named calls) are
/// looked for in ReaderOptions::subprogram_folder (read_siemens: the program's folder).
Toolpath read_siemens(const std::string& path, const ReaderOptions& options = {});
Toolpath parse_siemens(const std::string& text, const std::string& file_name_for_messages,
                       const ReaderOptions& options = {});

/// Reads a KUKA KRL program (subset above, "KUKA KRL subset"); declarations and BASE_DATA /
/// TOOL_DATA of the companion .dat file (same name, .dat) are read first where it exists.
/// Throws vmsim::InputError naming the file, line, column and word.
Toolpath read_krl(const std::string& path, const ReaderOptions& options = {});
/// `dat_text`: the companion .dat file's text (empty: none), named `dat_file` in messages.
Toolpath parse_krl(const std::string& text, const std::string& file_name_for_messages,
                   const ReaderOptions& options = {}, const std::string& dat_text = {},
                   const std::string& dat_file = {});

/// Picks the reader by extension: .apt .cl .cls -> APT; .mpf .spf -> Siemens 840D; .nc .ngc
/// .gcode .tap .iso .ptp .eia .cnc -> G-code, unless the text is unmistakably a Siemens program
/// (a `%_N_..._MPF` header, or a CYCLE832 / CYCLE800 call), which goes to the Siemens reader;
/// .h -> Heidenhain TNC conversational (heidenhain_reader.hpp); .src -> KUKA KRL.
Toolpath read_toolpath(const std::string& path, const ReaderOptions& options = {});

}  // namespace vmsim::toolpath
