# Reads VTU files with VTK's own reader (tests/tools/export.sh, when python3 has vtk):
#   vtk_read.py BINARY.vtu ASCII.vtu TETS.vtu
# the binary and ASCII files must hold the same values, and VTK's volume of the tetrahedral
# export must be pf's total volume to 1e-12 (VTK's volume of the polyhedron cells need not be:
# it assumes convex cells).
import sys, vtk
def np_(arr):  # values of a vtkDataArray as a list (no numpy needed)
    n = arr.GetNumberOfComponents()
    return [arr.GetComponent(i, c) for i in range(arr.GetNumberOfTuples()) for c in range(n)]
def read(p):
    r = vtk.vtkXMLUnstructuredGridReader(); r.SetFileName(p); r.Update(); return r.GetOutput()
a, b = read(sys.argv[1]), read(sys.argv[2])
assert a.GetNumberOfPoints() == b.GetNumberOfPoints() > 0 and a.GetNumberOfCells() == b.GetNumberOfCells() > 0
assert np_(a.GetPoints().GetData()) == np_(b.GetPoints().GetData())
for d in ("kind", "volume"):
    assert np_(a.GetCellData().GetArray(d)) == np_(b.GetCellData().GetArray(d)), d
def vtk_volume(g):
    f = vtk.vtkCellSizeFilter(); f.SetInputData(g); f.ComputeVolumeOn(); f.Update()
    return sum(np_(f.GetOutput().GetCellData().GetArray("Volume")))
t = read(sys.argv[3])
pf_total = sum(np_(a.GetCellData().GetArray("volume")))
print("vtk volume: cells %.17g tets %.17g pf %.17g" % (vtk_volume(a), vtk_volume(t), pf_total))
assert abs(vtk_volume(t) - pf_total) <= 1e-12 * pf_total
