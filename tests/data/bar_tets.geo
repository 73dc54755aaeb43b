// tests/data/bar_tets.msh: gmsh -3 bar_tets.geo -format msh22 (Gmsh 4.8.4, Debian 12): 1,036 tets,
// a real imported tetrahedral mesh (tests/tools/cut_sim.sh).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 4, 1, 1};
Physical Volume("bar") = {1};
s() = Surface In BoundingBox{-0.01, -0.01, -0.01, 0.01, 1.01, 1.01};
Physical Surface("clamp") = {s()};
Mesh.CharacteristicLengthMax = 0.3;
Mesh.MshFileVersion = 2.2;
