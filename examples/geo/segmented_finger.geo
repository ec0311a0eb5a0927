// The segmented finger of the finger-design study: N semicircular bellows of height H
// and wall TSB on a foot of thickness TOF, over a length L, as a half model (y >= 0).
// Chosen where the study is silent (docs/src/validation.md, "The segmented finger"):
// seen from the side each bellow is a half cylinder on straight walls (SIDE = 1), its
// cavity CAVITY long and CAVITY_W wide with the walls outside it (TSB at the ends and the
// top, SIDEWALL at the flat sides); bellows GAP apart from the clamp plane x = 0 on, the
// foot bare beyond; each segment's bellows joined by a channel CHANNEL high under a roof
// ROOF thick; a strain-limiting sheet on the bottom face (SHEET = 3, `layer.sheet`).
// The cavities are the study's two channels: `cavity.mcp`, the first NMCP bellows (the
// MCP segment), and `cavity.pip_dip`, the others.
// The readings of scripts/bench-finger.sh draw other choices: B, PITCH and W set the
// bellow's length, pitch and the width directly; SIDE = 0 tops each bellow with a half
// cylinder along the finger (radius W / 2); SHEET 1 and 2 put the sheet on the bellows'
// tops and sides, and also on their end walls.
SetFactory("OpenCASCADE");
DefineConstant[
  H = {10, Name "Parameters/H bellow height (mm)"},
  N = {12, Name "Parameters/N bellows"},
  TSB = {1, Name "Parameters/TSB bellow wall (mm)"},
  TOF = {1.25, Name "Parameters/TOF foot thickness (mm)"},
  L = {130, Name "Parameters/L length (mm)"},
  NMCP = {4, Name "Parameters/NMCP bellows of the MCP segment"},
  CAVITY = {3, Name "Parameters/CAVITY each bellow's cavity length (mm)"},
  CAVITY_W = {18, Name "Parameters/CAVITY_W the cavities' width (mm)"},
  SIDEWALL = {1, Name "Parameters/SIDEWALL the flat side walls (mm), 0: TSB"},
  GAP = {1.5, Name "Parameters/GAP between bellows (mm)"},
  CHANNEL = {2, Name "Parameters/CHANNEL height of a channel joining a segment's bellows (mm), 0: none"},
  ROOF = {1, Name "Parameters/ROOF the channel's roof between bellows (mm), 0: TSB"},
  SIDE = {1, Name "Parameters/SIDE 1: each bellow's top a half cylinder across the finger, 0: along it"},
  SHEET = {3, Name "Parameters/SHEET 0 none, 1 bellows' tops and sides, 2 and ends, 3 bottom"},
  B = {0, Name "Parameters/B bellow length (mm), 0: CAVITY + 2 TSB"},
  PITCH = {0, Name "Parameters/PITCH bellows this far apart (mm), 0: B + GAP"},
  W = {0, Name "Parameters/W width (mm), 0: CAVITY_W + 2 SIDEWALL"}
];
sw = TSB;
If (SIDEWALL > 0)
  sw = SIDEWALL;
EndIf
tb = CAVITY + 2 * TSB;
If (B > 0)
  tb = B;
EndIf
p = tb + GAP;
If (PITCH > 0)
  p = PITCH;
EndIf
wd = CAVITY_W + 2 * sw;
If (W > 0)
  wd = W;
EndIf
R = wd / 2;
Ri = R - sw;
If (SIDE == 0)
  Ri = R - TSB;
EndIf
zc = TOF + H - R;
e = 1e-4;

base = TOF;
roof = TSB;
If (ROOF > 0)
  roof = ROOF;
EndIf
If (CHANNEL > 0)
  base = TOF + CHANNEL + roof;
EndIf
Box(1) = {0, 0, 0, L, R, base};
outer() = {};
inner() = {};
For k In {0 : N - 1}
  x0 = k * p;
  If (SIDE == 0)
    c = newv; Cylinder(c) = {x0, 0, zc, tb, 0, 0, R};
    b = newv; Box(b) = {x0, 0, zc, tb, R, R};
    outer() += BooleanIntersection{ Volume{c}; Delete; }{ Volume{b}; Delete; };
    ci = newv; Cylinder(ci) = {x0 + TSB, 0, zc, tb - 2 * TSB, 0, 0, Ri};
    bi = newv; Box(bi) = {x0 + TSB, 0, zc, tb - 2 * TSB, Ri, Ri};
    inner() += BooleanIntersection{ Volume{ci}; Delete; }{ Volume{bi}; Delete; };
    If (zc - TOF > e)
      s = newv; Box(s) = {x0, 0, TOF, tb, R, zc - TOF};
      outer() += s;
      si = newv; Box(si) = {x0 + TSB, 0, TOF, tb - 2 * TSB, Ri, zc - TOF};
      inner() += si;
    EndIf
  Else
    // Seen from the side each bellow is a half cylinder of radius tb / 2 across the
    // width on straight walls; its sides are flat.
    rs = tb / 2;
    zs = TOF + H - rs;
    c = newv; Cylinder(c) = {x0 + rs, 0, zs, 0, R, 0, rs};
    b = newv; Box(b) = {x0, 0, TOF, tb, R, H - rs};
    outer() += BooleanUnion{ Volume{b}; Delete; }{ Volume{c}; Delete; };
    ci = newv; Cylinder(ci) = {x0 + rs, 0, zs, 0, Ri, 0, rs - TSB};
    bi = newv; Box(bi) = {x0 + TSB, 0, TOF, tb - 2 * TSB, Ri, H - rs};
    inner() += BooleanUnion{ Volume{bi}; Delete; }{ Volume{ci}; Delete; };
  EndIf
EndFor
// The channels: under the MCP segment's bellows, and under the PIP and DIP segments'.
If (CHANNEL > 0)
  ch = newv; Box(ch) = {TSB, 0, TOF, (NMCP - 1) * p + tb - 2 * TSB, Ri, CHANNEL};
  inner() += ch;
  ch = newv; Box(ch) = {NMCP * p + TSB, 0, TOF, (N - NMCP - 1) * p + tb - 2 * TSB, Ri, CHANNEL};
  inner() += ch;
EndIf
body() = BooleanUnion{ Volume{1}; Delete; }{ Volume{outer()}; Delete; };
If (#inner() > 1)
  cavities() = BooleanUnion{ Volume{inner(0)}; Delete; }{ Volume{inner({1 : #inner() - 1})}; Delete; };
Else
  cavities() = inner();
EndIf
solid() = BooleanDifference{ Volume{body()}; Delete; }{ Volume{cavities()}; Delete; };

// Markers on the bottom face, a quarter of the width from the symmetry plane.
bottom() = Surface In BoundingBox{-e, -e, -e, L + e, R + e, e};
nm = N + 1;
marks() = {};
For k In {0 : nm - 1}
  q = newp; Point(q) = {1 + k * (L - 2) / (nm - 1), R / 2, 0};
  marks() += q;
EndFor
Point{marks()} In Surface{bottom(0)};

Physical Volume("silicone") = solid();
Physical Surface("symmetry.y") = Surface In BoundingBox{-e, -e, -e, L + e, e, TOF + H + e};
Physical Surface("clamp") = Surface In BoundingBox{-e, -e, -e, e, R + e, TOF + H + e};
mcp() = Surface In BoundingBox{TSB - e, -e, TOF - e, (NMCP - 1) * p + tb - TSB + e, Ri + e, TOF + H - TSB + e};
pd() = Surface In BoundingBox{NMCP * p + TSB - e, -e, TOF - e, (N - 1) * p + tb - TSB + e, Ri + e, TOF + H - TSB + e};
Physical Surface("cavity.mcp") = mcp();
Physical Surface("cavity.pip_dip") = pd();
Physical Point("markers") = marks();
Physical Point("tip") = Point In BoundingBox{L - e, -e, -e, L + e, e, e};

If (SHEET == 3)
  Physical Surface("layer.sheet") = Surface In BoundingBox{-e, -e, -e, L + e, R + e, e};
EndIf
If (SHEET > 0 && SHEET < 3)
  sh() = {};
  For k In {0 : N - 1}
    x0 = k * p;
    all() = Surface In BoundingBox{x0 - e, -e, TOF - e, x0 + tb + e, R + e, TOF + H + e};
    all() -= Surface In BoundingBox{x0 + TSB - e, -e, TOF - e, x0 + tb - TSB + e, Ri + e, TOF + H - TSB + e};
    all() -= Surface In BoundingBox{x0 - e, -e, -e, x0 + tb + e, e, TOF + H + e};
    If (SHEET < 2)
      all() -= Surface In BoundingBox{x0 - e, -e, -e, x0 + e, R + e, TOF + H + e};
      all() -= Surface In BoundingBox{x0 + tb - e, -e, -e, x0 + tb + e, R + e, TOF + H + e};
    EndIf
    sh() += all();
  EndFor
  Physical Surface("layer.sheet") = sh();
EndIf
