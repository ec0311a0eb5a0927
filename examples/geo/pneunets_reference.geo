// The reference PneuNets actuator (bendscope simulate --print-config; the letters of
// src/fem/shapes/pneunets.rs) as CAD for gmsh: the half y >= 0 of the actuator, with
// the parts bendscope reads named as physical groups:
//   silicone     the volume beyond the clamp
//   clamp        the first chamber block (x <= c), held whole as the built-in mesh
//                holds it
//   symmetry.y   the plane y = 0
//   cavity       the inner surfaces of the chambers and the channel
//   markers      side face y = i/2, centres of blocks 2..N, mid cavity height
//   tip          the free end's bottom edge on the symmetry plane (b, 0, 0)
// Mesh: gmsh pneunets_reference.geo -3 -order 2 -format msh41 -clmax 1.5 -o pneunets.msh
// Any parameter: -setnumber chambers 7 (and so on).
SetFactory("OpenCASCADE");

DefineConstant[
  chambers = {9, Name "Parameters/chambers"},
  b = {116, Name "Parameters/b (length)"},
  i = {15, Name "Parameters/i (width)"},
  f = {6, Name "Parameters/f (base height)"},
  m = {2, Name "Parameters/m (channel height)"},
  p = {7, Name "Parameters/p (channel width)"},
  r = {105, Name "Parameters/r (channel length)"},
  c = {13.75, Name "Parameters/c (first and last block length)"},
  g = {11.5, Name "Parameters/g (block length)"},
  d = {1, Name "Parameters/d (gap)"},
  e = {5, Name "Parameters/e (cavity length)"},
  l = {11, Name "Parameters/l (cavity width)"},
  n = {12, Name "Parameters/n (cavity height)"},
  top_wall = {3.5, Name "Parameters/top_wall"},
  roof = {1, Name "Parameters/roof (wall over the channel under a gap)"}
];

a = f + m + n + top_wall; // height
zc = f + m;               // channel top = cavity floor
zg = zc + roof;           // gap bottom
zt = zc + n;              // cavity top
eps = 1e-6;

// The clamped block and the rest, cut apart at x = c so that the clamp has surfaces.
Box(1) = {0, 0, 0, c, i / 2, a};
Box(2) = {c, 0, 0, b - c, i / 2, a};

// Cavities, gaps and the channel; boxes reach past the outer faces for clean cuts.
cuts() = {};
x = 0;
For k In {0 : chambers - 1}
  len = g;
  If (k == 0 || k == chambers - 1)
    len = c;
  EndIf
  v = newv; Box(v) = {x + len / 2 - e / 2, -1, zc, e, l / 2 + 1, n};
  cuts() += v;
  If (k < chambers - 1)
    v = newv; Box(v) = {x + len, -1, zg, d, i / 2 + 2, a - zg + 1};
    cuts() += v;
  EndIf
  x += len + d;
EndFor
v = newv; Box(v) = {(b - r) / 2, -1, f, r, p / 2 + 1, m};
cuts() += v;

left() = BooleanDifference{ Volume{1}; Delete; }{ Volume{cuts()}; };
right() = BooleanDifference{ Volume{2}; Delete; }{ Volume{cuts()}; Delete; };
BooleanFragments{ Volume{left(), right()}; Delete; }{}

// Markers, embedded in the side face y = i/2.
markers() = {};
x = 0;
For k In {0 : chambers - 1}
  len = g;
  If (k == 0 || k == chambers - 1)
    len = c;
  EndIf
  If (k > 0)
    pt = newp; Point(pt) = {x + len / 2, i / 2, zc + n / 2};
    markers() += pt;
  EndIf
  x += len + d;
EndFor
side() = Surface In BoundingBox{c - eps, i / 2 - eps, -eps, b + eps, i / 2 + eps, a + eps};
Point{markers()} In Surface{side(0)};

cavity() = Surface In BoundingBox{(b - r) / 2 - eps, -eps, f - eps, (b + r) / 2 + eps, p / 2 + eps, zc + eps};
x = 0;
For k In {0 : chambers - 1}
  len = g;
  If (k == 0 || k == chambers - 1)
    len = c;
  EndIf
  cavity() += Surface In BoundingBox{x + len / 2 - e / 2 - eps, -eps, zc - eps, x + len / 2 + e / 2 + eps, l / 2 + eps, zt + eps};
  x += len + d;
EndFor

Physical Volume("clamp") = Volume In BoundingBox{-eps, -eps, -eps, c + eps, i / 2 + eps, a + eps};
Physical Volume("silicone") = Volume In BoundingBox{c - eps, -eps, -eps, b + eps, i / 2 + eps, a + eps};
Physical Surface("symmetry.y") = Surface In BoundingBox{-eps, -eps, -eps, b + eps, eps, a + eps};
Physical Surface("cavity") = cavity();
Physical Point("markers") = markers();
Physical Point("tip") = Point In BoundingBox{b - eps, -eps, -eps, b + eps, eps, eps};
