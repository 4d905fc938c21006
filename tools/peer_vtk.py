#!/usr/bin/python3
"""peer_vtk.py: one of make bench's peers. Renders a raw int16 volume (ctlab's phantom) with
VTK's CPU ray caster, vtkFixedPointVolumeRayCastMapper (python3-vtk9), in one of the bench's
cases, and times it. Needs an X display: run it under `xvfb-run -a`.

  /usr/bin/python3 tools/peer_vtk.py RAW NX NY NZ CASE WIDTH HEIGHT RUNS OUT.ppm [THREADS]

CASE: a (composite, unlit, top view), b (composite, lit, top view), c (composite, unlit,
oblique: ctlab's orbit camera at azimuth 30, elevation 20, the bounding sphere filling
the image), d (maximum
intensity, top view). Spacing 1,1,1; the classic transfer function as piecewise functions
with sharp steps. THREADS: VTK's own threads (default: every core).
Prints one line:
  peer=vtk case=C size=WxH threads=T first_ms=F cold_ms=F warm_ms=M renders=N
first: the first Render() (VTK builds its quantised normals and min-max blocks inside it),
warm: the median of the other RUNS - 1, each forced to render again by moving the camera
0.01 along its axis and back. Settings: ../shared/performance.md (one ray per pixel, sample
distance 1, opacity unit distance 1, no automatic adjustment, parallel projection).
"""
import sys
import time

import numpy
import vtk
from vtk.util import numpy_support

SKIN_LOW, SKIN_HIGH, BONE_LOW = -300.0, 50.0, 300.0  # the classic table's edges (CT values)
SKIN_RGB, BONE_RGB = (1.0, 0.79, 0.6), (1.0, 1.0, 1.0)
SKIN_OPACITY, BONE_OPACITY = 0.12, 0.8               # per unit of length (spacing 1)
EDGE = 1e-3        # CT units: a step's width (a sharp edge in a piecewise-linear function)
AMBIENT, DIFFUSE, SPECULAR, SPECULAR_POWER = 0.2, 0.7, 0.1, 10.0
AZIMUTH_DEG, ELEVATION_DEG = 30.0, 20.0  # case c, as ctlab's --azimuth, --elevation
NUDGE = 0.01       # world units: camera move between frames, forcing a new render
MAX_SIDE = 4096


def fail(message):
    print("peer_vtk: " + message, file=sys.stderr)
    sys.exit(2)


def whole(name, text, low, high):
    try:
        value = int(text)
    except ValueError:
        fail("%s: expected a whole number %d..%d, got '%s'" % (name, low, high, text))
    if not low <= value <= high:
        fail("%s: expected a whole number %d..%d, got '%s'" % (name, low, high, text))
    return value


def step_function(function, low, high, levels):
    """Adds the classic table's steps to a piecewise function: `levels` gives the value on
    v < -300, [-300, 50), [50, 300) and >= 300 (tuples for colour)."""
    below, skin, gap, bone = levels
    points = [(low, below), (SKIN_LOW - EDGE, below), (SKIN_LOW, skin), (SKIN_HIGH - EDGE, skin),
              (SKIN_HIGH, gap), (BONE_LOW - EDGE, gap), (BONE_LOW, bone), (high, bone)]
    for value, level in points:
        if isinstance(level, tuple):
            function.AddRGBPoint(value, *level)
        else:
            function.AddPoint(value, level)


def main(argv):
    if len(argv) == 2 and argv[1] == "--help":
        print(__doc__)
        return 0
    if len(argv) not in (10, 11):
        fail("usage: peer_vtk.py RAW NX NY NZ CASE(a|b|c|d) WIDTH HEIGHT RUNS OUT.ppm [THREADS]")
    nx, ny, nz = (whole(name, text, 2, 4096) for name, text in zip("XYZ", argv[2:5]))
    case = argv[5]
    if case not in ("a", "b", "c", "d"):
        fail("CASE: expected a, b, c or d, got '%s'" % case)
    width, height = whole("WIDTH", argv[6], 1, MAX_SIDE), whole("HEIGHT", argv[7], 1, MAX_SIDE)
    runs = whole("RUNS", argv[8], 1, 10000)
    out_path = argv[9]
    threads = whole("THREADS", argv[10], 1, 1024) if len(argv) == 11 else 0

    try:
        values = numpy.fromfile(argv[1], dtype="<i2")
    except OSError as error:
        fail("cannot read the volume '%s': %s" % (argv[1], error))
    if values.size != nx * ny * nz:
        fail("the volume '%s' is not NX*NY*NZ int16 values" % argv[1])
    # The data at spacing 1,1,1, origin 0: world x = i, y = j, z = k.
    image = vtk.vtkImageData()
    image.SetDimensions(nx, ny, nz)
    image.SetSpacing(1, 1, 1)
    image.SetOrigin(0, 0, 0)
    array = numpy_support.numpy_to_vtk(values.astype(numpy.int16), deep=True,
                                       array_type=vtk.VTK_SHORT)
    image.GetPointData().SetScalars(array)
    low, high = float(values.min()) - 1, float(values.max()) + 1

    colour = vtk.vtkColorTransferFunction()
    opacity = vtk.vtkPiecewiseFunction()
    step_function(colour, min(low, SKIN_LOW - 2), max(high, BONE_LOW + 1),
                  ((0.0, 0.0, 0.0), SKIN_RGB, (0.0, 0.0, 0.0), BONE_RGB))
    step_function(opacity, min(low, SKIN_LOW - 2), max(high, BONE_LOW + 1),
                  (0.0, SKIN_OPACITY, 0.0, BONE_OPACITY))
    properties = vtk.vtkVolumeProperty()
    properties.SetColor(colour)
    properties.SetScalarOpacity(opacity)
    properties.SetScalarOpacityUnitDistance(1.0)
    properties.SetInterpolationTypeToLinear()
    if case == "b":
        properties.ShadeOn()
        properties.SetAmbient(AMBIENT)
        properties.SetDiffuse(DIFFUSE)
        properties.SetSpecular(SPECULAR)
        properties.SetSpecularPower(SPECULAR_POWER)
    else:
        properties.ShadeOff()

    mapper = vtk.vtkFixedPointVolumeRayCastMapper()
    mapper.SetInputData(image)
    mapper.SetSampleDistance(1.0)
    mapper.SetImageSampleDistance(1.0)
    mapper.AutoAdjustSampleDistancesOff()
    mapper.LockSampleDistanceToInputSpacingOff()
    if threads:
        mapper.SetNumberOfThreads(threads)
    if case == "d":
        mapper.SetBlendModeToMaximumIntensity()
    volume = vtk.vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(properties)

    renderer = vtk.vtkRenderer()
    renderer.SetBackground(0, 0, 0)
    renderer.AddVolume(volume)
    renderer.RemoveAllLights()
    renderer.AutomaticLightCreationOff()
    light = vtk.vtkLight()
    light.SetLightTypeToHeadlight()
    renderer.AddLight(light)
    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(width, height)
    window.AddRenderer(renderer)

    # ctlab's cameras. Top view: from the crown (k = 0) along +k, image rows along +j, columns
    # along +i. Oblique: ctlab's orbit camera (steps/10): azimuth 0 faces the face looking
    # along +j, 90 looks along +i, elevation 90 looks down from the crown; up is the crown, -k.
    centre = numpy.array([(nx - 1) / 2.0, (ny - 1) / 2.0, (nz - 1) / 2.0])
    if case == "c":
        azimuth, elevation = numpy.radians(AZIMUTH_DEG), numpy.radians(ELEVATION_DEG)
        forward = numpy.array([numpy.sin(azimuth) * numpy.cos(elevation),
                               numpy.cos(azimuth) * numpy.cos(elevation), numpy.sin(elevation)])
        up = numpy.array([0.0, 0.0, -1.0])
        # The bounding sphere of the voxel centres (0..n-1) fills it, as ctlab's --zoom.
        scale = 0.5 * ((nx - 1) ** 2 + (ny - 1) ** 2 + (nz - 1) ** 2) ** 0.5
    else:
        forward, up = numpy.array([0.0, 0.0, 1.0]), numpy.array([0.0, -1.0, 0.0])
        scale = 0.5 * height  # one pixel per voxel
    camera = renderer.GetActiveCamera()
    camera.ParallelProjectionOn()
    distance = 2.0 * max(nx, ny, nz)
    camera.SetFocalPoint(*centre)
    camera.SetPosition(*(centre - distance * forward))
    camera.SetViewUp(*up)
    camera.OrthogonalizeViewUp()
    camera.SetParallelScale(scale)
    camera.SetClippingRange(1.0, 4.0 * distance)

    times = []
    direction = numpy.array(camera.GetDirectionOfProjection())
    position = numpy.array(camera.GetPosition())
    for run in range(runs):
        # Every frame a new one: the camera moves NUDGE along its axis (and back).
        camera.SetPosition(*(position + (NUDGE if run % 2 else 0.0) * direction))
        start = time.perf_counter()
        window.Render()
        window.WaitForCompletion()
        times.append((time.perf_counter() - start) * 1e3)

    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.SetInputBufferTypeToRGB()
    grab.ReadFrontBufferOff()
    grab.Update()
    shot = grab.GetOutput()
    w, h, _ = shot.GetDimensions()
    pixels = numpy_support.vtk_to_numpy(shot.GetPointData().GetScalars()).reshape(h, w, -1)
    pixels = pixels[::-1, :, :3]  # VTK's rows run bottom up: the file's top first
    with open(out_path, "wb") as out:
        out.write(b"P6\n%d %d\n255\n" % (w, h))
        out.write(numpy.ascontiguousarray(pixels, dtype=numpy.uint8).tobytes())

    warm = sorted(times[1:]) if runs > 1 else times[:1]
    n = len(warm)
    median = warm[n // 2] if n % 2 else (warm[n // 2 - 1] + warm[n // 2]) / 2
    used = mapper.GetNumberOfThreads()
    print("peer=vtk case=%s size=%dx%d threads=%d first_ms=%.3f cold_ms=%.3f warm_ms=%.3f "
          "renders=%d" % (case, width, height, used, times[0], times[0], median, runs))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
