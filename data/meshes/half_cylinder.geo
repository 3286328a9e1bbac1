// A half-cylinder (2D: half disk) of radius 1 graded towards its lowest or highest point, for the
// two-cylinder Hertz scene data/scenes/twobody_gmsh_cylinders.toml. Regenerate both bodies with
// scripts/make_half_cylinders.sh (Gmsh 4.8.4, Debian's gmsh package):
//   yc = +1: the upper body, centre (0, 1), the arc below (touching the origin), the flat side on top;
//   yc = -1: the lower body, centre (0, -1), the arc above, the flat side at the bottom.
// Element sizes: hmin within 0.02 of the contact point, growing linearly to hmax at distance 0.6.
// Physical curves: "arc" (the curved side), "flat" (the diameter); physical surface "body".
SetFactory("Built-in");
If (!Exists(yc)) yc = 1; EndIf
If (!Exists(hmin)) hmin = 0.003; EndIf
If (!Exists(hmax)) hmax = 0.06; EndIf
R = 1;
s = (yc > 0) ? -1 : 1;
Point(1) = {0, yc, 0, hmax};
Point(2) = {-R, yc, 0, hmax};
Point(3) = {R, yc, 0, hmax};
Point(4) = {0, yc + s * R, 0, hmin};
Circle(1) = {2, 1, 4};
Circle(2) = {4, 1, 3};
Line(3) = {3, 2};
Curve Loop(1) = {1, 2, 3};
Plane Surface(1) = {1};
Field[1] = Distance;
Field[1].PointsList = {4};
Field[2] = Threshold;
Field[2].InField = 1;
Field[2].SizeMin = hmin;
Field[2].SizeMax = hmax;
Field[2].DistMin = 0.02;
Field[2].DistMax = 0.6;
Background Field = 2;
Mesh.MeshSizeExtendFromBoundary = 0;
Mesh.MeshSizeFromPoints = 0;
Mesh.MeshSizeFromCurvature = 0;
Physical Curve("arc") = {1, 2};
Physical Curve("flat") = {3};
Physical Surface("body") = {1};
