// The two bodies of the 3D Cattaneo-Mindlin scene data/scenes/cattaneo_mindlin_3d.toml, graded towards
// the point where they touch (the origin). Regenerate with scripts/make_cattaneo_mindlin_3d.sh (Gmsh
// 4.8.4, Debian's gmsh package, OpenCASCADE kernel):
//   "ball": the lower half of the ball of radius 1 centred at (0, 0, 1), touching the origin;
//   "block": the box [-1, 1] x [-1, 1] x [-1, 0], its top face through the origin.
// Element sizes h(x) = min(hmax, hmin + grade |x|): hmin at the origin, hmax from |x| = 1.
// Physical volumes "ball", "block"; physical surfaces "surface" (the ball's curved side), "top" (its
// flat disc at z = 1), "block_top" (z = 0), "bottom" (z = -1).
SetFactory("OpenCASCADE");
If (!Exists(hmin)) hmin = 0.015; EndIf
If (!Exists(hmax)) hmax = 0.25; EndIf
If (!Exists(grade)) grade = 0.2; EndIf
R = 1;
Sphere(1) = {0, 0, R, R};
Box(2) = {-2, -2, R, 4, 4, 2};
BooleanDifference(3) = { Volume{1}; Delete; }{ Volume{2}; Delete; };
Box(4) = {-1, -1, -1, 2, 2, 1};
e = 1e-6;
ballTop() = Surface In BoundingBox{-R - e, -R - e, R - e, R + e, R + e, R + e};
ballCurved() = Abs(Boundary{ Volume{3}; });
ballCurved() -= ballTop();
blockTop() = Surface In BoundingBox{-1 - e, -1 - e, -e, 1 + e, 1 + e, e};
blockBottom() = Surface In BoundingBox{-1 - e, -1 - e, -1 - e, 1 + e, 1 + e, -1 + e};
Field[1] = MathEval;
Field[1].F = Sprintf("Min(%g, %g + %g * Sqrt(x^2 + y^2 + z^2))", hmax, hmin, grade);
Background Field = 1;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Volume("ball") = {3};
Physical Volume("block") = {4};
Physical Surface("surface") = {ballCurved()};
Physical Surface("top") = {ballTop()};
Physical Surface("block_top") = {blockTop()};
Physical Surface("bottom") = {blockBottom()};
