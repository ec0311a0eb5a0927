// The segmented finger of the finger-design study: N semicircular bellows of height H
// and wall TSB on a foot of thickness TOF, over a length L, as a half model (y >= 0).
// Chosen where the study is silent (docs/src/validation.md, "The segmented finger"):
// width W = 20 mm with the bellow's top a half cylinder across the whole width (radius
// W / 2; straight side walls below it when H > W / 2), gaps of 1.5 mm between bellows,
// the first bellow's end wall in the clamp plane x = 0, the foot as long as the finger,
// no channel, one silicone. The cavities are the study's two channels: `cavity.mcp`,
// the first NMCP bellows (the MCP segment), and `cavity.pip_dip`, the others.
SetFactory("OpenCASCADE");
DefineConstant[
  H = {10, Name "Parameters/H bellow height (mm)"},
  N = {12, Name "Parameters/N bellows"},
  TSB = {1, Name "Parameters/TSB bellow wall (mm)"},
  TOF = {1.25, Name "Parameters/TOF foot thickness (mm)"},
  L = {130, Name "Parameters/L length (mm)"},
  W = {20, Name "Parameters/W width (mm)"},
  gap = {1.5, Name "Parameters/gap between bellows (mm)"},
  NMCP = {4, Name "Parameters/NMCP bellows of the MCP segment"}
];
R = W / 2;
Ri = R - TSB;
zc = TOF + H - R;
p = L / N;
tb = p - gap;
e = 1e-4;

Box(1) = {0, 0, 0, L, R, TOF};
outer() = {};
inner() = {};
For k In {0 : N - 1}
  x0 = k * p;
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
EndFor
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
mcp() = {};
pd() = {};
For k In {0 : N - 1}
  x0 = k * p;
  If (k < NMCP)
    mcp() += Surface In BoundingBox{x0 + TSB - e, -e, TOF - e, x0 + tb - TSB + e, Ri + e, TOF + H - TSB + e};
  Else
    pd() += Surface In BoundingBox{x0 + TSB - e, -e, TOF - e, x0 + tb - TSB + e, Ri + e, TOF + H - TSB + e};
  EndIf
EndFor
Physical Surface("cavity.mcp") = mcp();
Physical Surface("cavity.pip_dip") = pd();
Physical Point("markers") = marks();
Physical Point("tip") = Point In BoundingBox{L - e, -e, -e, L + e, e, e};
