"""Render the last frame of a snapshot file (``millsim run ... --snapshots``) with VTK, reading
its XDMF sidecar with VTK's XDMF reader, as ParaView does: the figure of docs/pipeline.md.

Left: the particles (spheres at their radius, coloured by speed) in the walls; right: the
contact network of the same frame (tubes, radius and colour by the normal force) in the walls.
Plane walls (a drum's end walls) are left out so that one sees in.

VTK is not a dependency of millsim: ``pip install vtk`` into the environment that runs this.
Offscreen: ``VTK_DEFAULT_OPENGL_WINDOW=vtkOSOpenGLRenderWindow`` where there is no display.

    millsim run packing --set container=drum --set liner=examples/meshes/ballmill_liner.stl \\
        --set drum_radius=0.1 --set drum_length=0.05 --set n=400 --set radius=0.004 \\
        --set drum_omega=4 --set settle_steps=20000 --set spinup_steps=20000 --set dt=1e-5 \\
        --set steps=20000 --set record_every=2000 --out mill.nc --snapshots mill.h5 \\
        --snapshot-contacts
    python tools/render_snapshot.py mill.xdmf docs/figures/paraview_mill.png
"""

import argparse

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy


def _blocks(path):
    reader = vtk.vtkXdmfReader()
    reader.SetFileName(str(path))
    reader.UpdateInformation()
    info = reader.GetOutputInformation(0)
    times = info.Get(vtk.vtkStreamingDemandDrivenPipeline.TIME_STEPS())
    if times:
        reader.UpdateTimeStep(times[-1])
    else:
        reader.Update()
    out = reader.GetOutputDataObject(0)
    blocks = {}
    it = out.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        name = it.GetCurrentMetaData().Get(vtk.vtkCompositeDataSet.NAME())
        blocks[name] = it.GetCurrentDataObject()
        it.GoToNextItem()
    return blocks, (times[-1] if times else 0.0)


def _array(data, name, cells=False):
    store = data.GetCellData() if cells else data.GetPointData()
    return vtk_to_numpy(store.GetArray(name))


def _walls_actor(walls):
    kind = _array(walls, "kind", cells=True)
    keep = vtk.vtkThreshold()  # every wall but the planes
    keep.SetInputData(walls)
    keep.SetInputArrayToProcess(0, 0, 0, vtk.vtkDataObject.FIELD_ASSOCIATION_CELLS, "kind")
    keep.SetLowerThreshold(0.5)
    keep.SetUpperThreshold(float(kind.max()) + 0.5)
    surface = vtk.vtkGeometryFilter()
    surface.SetInputConnection(keep.GetOutputPort())
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(surface.GetOutputPort())
    mapper.ScalarVisibilityOff()
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    actor.GetProperty().SetColor(0.62, 0.62, 0.66)
    actor.GetProperty().SetOpacity(0.55)
    return actor


def _lut(lo, hi, hue):
    lut = vtk.vtkLookupTable()
    lut.SetTableRange(lo, hi)
    lut.SetHueRange(*hue)
    lut.Build()
    return lut


def _bar(lut, title):
    """A colour bar at the right with its title above it (a text of its own: the bar's own
    title is drawn too small to read at this size)."""
    bar = vtk.vtkScalarBarActor()
    bar.SetLookupTable(lut)
    bar.SetNumberOfLabels(4)
    bar.SetWidth(0.1)
    bar.SetHeight(0.45)
    bar.SetPosition(0.86, 0.08)
    prop = bar.GetLabelTextProperty()
    prop.SetColor(0.1, 0.1, 0.1)
    prop.ItalicOff()
    prop.ShadowOff()
    text = vtk.vtkTextActor()
    text.SetInput(title)
    text.GetTextProperty().SetFontSize(18)
    text.GetTextProperty().SetColor(0.1, 0.1, 0.1)
    text.GetTextProperty().SetJustificationToRight()
    text.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
    text.GetPositionCoordinate().SetValue(0.97, 0.56)
    return bar, text


def _particles_actor(particles):
    poly = vtk.vtkPolyData()
    poly.SetPoints(particles.GetPoints())
    speed = np.linalg.norm(_array(particles, "velocity"), axis=1)
    radius = _array(particles, "radius")
    scalars = numpy_to_vtk(np.ascontiguousarray(radius), deep=True)
    scalars.SetName("radius")
    colour = numpy_to_vtk(np.ascontiguousarray(speed), deep=True)
    colour.SetName("speed")
    poly.GetPointData().AddArray(scalars)
    poly.GetPointData().AddArray(colour)
    poly.GetPointData().SetActiveScalars("radius")
    sphere = vtk.vtkSphereSource()
    sphere.SetRadius(1.0)
    sphere.SetThetaResolution(16)
    sphere.SetPhiResolution(12)
    glyph = vtk.vtkGlyph3D()
    glyph.SetInputData(poly)
    glyph.SetSourceConnection(sphere.GetOutputPort())
    glyph.SetScaleModeToScaleByScalar()
    glyph.SetScaleFactor(1.0)
    glyph.SetColorModeToColorByScalar()
    glyph.Update()
    out = glyph.GetOutput()
    # colour the glyphs by speed: repeat each particle's speed over its sphere's points
    per = out.GetNumberOfPoints() // max(len(speed), 1)
    colours = numpy_to_vtk(np.repeat(speed, per), deep=True)
    colours.SetName("speed")
    out.GetPointData().SetScalars(colours)
    lut = _lut(0.0, float(speed.max()) or 1.0, (0.667, 0.0))
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputData(out)
    mapper.SetLookupTable(lut)
    mapper.SetScalarRange(lut.GetTableRange())
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    return actor, _bar(lut, "speed [m s-1]")


def _contacts_actor(contacts):
    fn = np.linalg.norm(_array(contacts, "normal_force", cells=True), axis=1)
    to_points = vtk.vtkCellDataToPointData()
    data = vtk.vtkPolyData()
    data.SetPoints(contacts.GetPoints())
    data.SetLines(_lines(contacts))
    mag = numpy_to_vtk(np.ascontiguousarray(fn), deep=True)
    mag.SetName("normal force")
    data.GetCellData().SetScalars(mag)
    to_points.SetInputData(data)
    tube = vtk.vtkTubeFilter()
    tube.SetInputConnection(to_points.GetOutputPort())
    top = float(np.percentile(fn, 99)) if len(fn) else 1.0
    tube.SetRadius(0.0004)
    tube.SetRadiusFactor(6.0)
    tube.SetVaryRadiusToVaryRadiusByScalar()
    tube.SetNumberOfSides(8)
    lut = _lut(0.0, top, (0.15, 0.0))
    lut.SetSaturationRange(1.0, 1.0)
    lut.SetValueRange(0.35, 1.0)
    mapper = vtk.vtkPolyDataMapper()
    mapper.SetInputConnection(tube.GetOutputPort())
    mapper.SetLookupTable(lut)
    mapper.SetScalarRange(0.0, top)
    actor = vtk.vtkActor()
    actor.SetMapper(mapper)
    return actor, _bar(lut, "normal force [N]")


def _lines(grid):
    lines = vtk.vtkCellArray()
    for c in range(grid.GetNumberOfCells()):
        ids = grid.GetCell(c).GetPointIds()
        lines.InsertNextCell(ids.GetNumberOfIds())
        for k in range(ids.GetNumberOfIds()):
            lines.InsertCellPoint(ids.GetId(k))
    return lines


def _caption(text):
    actor = vtk.vtkTextActor()
    actor.SetInput(text)
    prop = actor.GetTextProperty()
    prop.SetFontSize(18)
    prop.SetColor(0.1, 0.1, 0.1)
    actor.SetPosition(14, 14)
    return actor


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("xdmf")
    parser.add_argument("out")
    parser.add_argument("--size", type=int, nargs=2, default=(1600, 760))
    args = parser.parse_args()
    blocks, time = _blocks(args.xdmf)
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(*args.size)
    camera = None
    panels = [("particles", _particles_actor(blocks["particles"]),
               f"particles by speed, t = {time:.3g} s")]
    if "contacts" in blocks:
        panels.append(("contacts", _contacts_actor(blocks["contacts"]),
                       "contact network by normal force"))
    for k, (_, (actor, bar), caption) in enumerate(panels):
        renderer = vtk.vtkRenderer()
        renderer.SetViewport(k / len(panels), 0.0, (k + 1) / len(panels), 1.0)
        renderer.SetBackground(1.0, 1.0, 1.0)
        renderer.AddActor(_walls_actor(blocks["walls"]))
        renderer.AddActor(actor)
        for prop in bar:
            renderer.AddViewProp(prop)
        renderer.AddViewProp(_caption(caption))
        if camera is None:
            renderer.ResetCamera()
            camera = renderer.GetActiveCamera()
            # the drum's axis is y: look in along it, a little from above and aside
            camera.SetFocalPoint(0.0, 0.025, 0.0)
            camera.SetPosition(0.12, -0.42, 0.14)
            camera.SetViewUp(0.0, 0.0, 1.0)
            renderer.ResetCameraClippingRange()
        else:
            renderer.SetActiveCamera(camera)
        window.AddRenderer(renderer)
    window.Render()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetFileName(args.out)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()


if __name__ == "__main__":
    main()
