#!/usr/bin/python3
"""Writes the OpenFOAM v1912 case of the CFD benchmark (bench/cfd/run_cfd.sh, docs/export.md).

    make_case.py CASE BED_STL --radius-mm R --bed-height-mm H [--cell-mm 0.5] [--level 1]
                 [--extension-mm 3.2] [--nu-mm2-s 1000] [--velocity-mm-s 1] [--iterations 3000]

The case is in mm (lengths mm, velocities mm/s, nu mm^2/s, kinematic pressure mm^2/s^2):
OpenFOAM only checks dimensions, and the STL from `voxpack export` is in mm, so nothing
is rescaled. Geometry:
  - background block: the square around the tube, z from -extension to H + extension
    (the column's own z range is [0, H]; the blocks' faces avoid z = 0 and z = H so the
    sampling planes there do not fall on cell faces);
  - tube.stl: the round wall (radius R, an open polygonal cylinder, 512 segments, longer
    than the block) written here; cells outside it are removed by snappyHexMesh;
  - constant/triSurface/bed.stl: the exported bed (`--contacts bridge --wall-contacts
    side --no-wall`), one closed solid; its bridges to the round wall stick out of the
    tube and are cut away with the outside.
Boundary conditions: uniform velocity at the inlet (z min), p = 0 at the outlet (z max),
no slip on the bed and the tube. Function objects write the area-averaged pressure on the
planes z = 0 and z = H (the column's faces) and the flux through the inlet.
"""
import argparse
import math
import os
import shutil

HEADER = """FoamFile
{{
    version     2.0;
    format      ascii;
    class       {cls};
    object      {obj};
}}
"""


def write(case, rel, cls, obj, body):
    path = os.path.join(case, rel)
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(HEADER.format(cls=cls, obj=obj) + body)


def tube_stl(path, radius, z0, z1, segments=512):
    """Open cylinder (side only), normals pointing out of the fluid (outwards)."""
    with open(path, "w") as f:
        f.write("solid tube\n")
        for s in range(segments):
            a0 = 2 * math.pi * s / segments
            a1 = 2 * math.pi * (s + 1) / segments
            p = [(radius * math.cos(a0), radius * math.sin(a0)),
                 (radius * math.cos(a1), radius * math.sin(a1))]
            quad = [(p[0][0], p[0][1], z0), (p[1][0], p[1][1], z0), (p[1][0], p[1][1], z1),
                    (p[0][0], p[0][1], z1)]
            am = 0.5 * (a0 + a1)
            n = (math.cos(am), math.sin(am), 0.0)
            for tri in ((quad[0], quad[1], quad[2]), (quad[0], quad[2], quad[3])):
                f.write(" facet normal %.9g %.9g %.9g\n  outer loop\n" % n)
                for v in tri:
                    f.write("   vertex %.9g %.9g %.9g\n" % v)
                f.write("  endloop\n endfacet\n")
        f.write("endsolid tube\n")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("case")
    ap.add_argument("bed_stl")
    ap.add_argument("--radius-mm", type=float, required=True)
    ap.add_argument("--bed-height-mm", type=float, required=True)
    ap.add_argument("--cell-mm", type=float, default=0.5)
    ap.add_argument("--level", type=int, default=1)
    ap.add_argument("--extension-mm", type=float, default=3.2)
    ap.add_argument("--nu-mm2-s", type=float, default=1000.0)
    ap.add_argument("--velocity-mm-s", type=float, default=1.0)
    ap.add_argument("--iterations", type=int, default=3000)
    a = ap.parse_args()
    case, R, H = a.case, a.radius_mm, a.bed_height_mm
    half = R * 1.08
    nxy = max(4, round(2 * half / a.cell_mm))
    zlo, zhi = -a.extension_mm, H + a.extension_mm
    nz = max(4, round((zhi - zlo) / a.cell_mm))
    os.makedirs(os.path.join(case, "constant", "triSurface"), exist_ok=True)
    shutil.copyfile(a.bed_stl, os.path.join(case, "constant", "triSurface", "bed.stl"))
    tube_stl(os.path.join(case, "constant", "triSurface", "tube.stl"), R, zlo - 1, zhi + 1)

    write(case, "system/blockMeshDict", "dictionary", "blockMeshDict", f"""
convertToMeters 1;
vertices
(
    ({-half} {-half} {zlo}) ({half} {-half} {zlo}) ({half} {half} {zlo}) ({-half} {half} {zlo})
    ({-half} {-half} {zhi}) ({half} {-half} {zhi}) ({half} {half} {zhi}) ({-half} {half} {zhi})
);
blocks ( hex (0 1 2 3 4 5 6 7) ({nxy} {nxy} {nz}) simpleGrading (1 1 1) );
edges ();
boundary
(
    inlet  {{ type patch; faces ((0 3 2 1)); }}
    outlet {{ type patch; faces ((4 5 6 7)); }}
    outside {{ type wall; faces ((0 1 5 4) (1 2 6 5) (2 3 7 6) (3 0 4 7)); }}
);
mergePatchPairs ();
""")
    lvl = a.level
    write(case, "system/snappyHexMeshDict", "dictionary", "snappyHexMeshDict", f"""
castellatedMesh true;
snap            true;
addLayers       false;
geometry
{{
    bed.stl  {{ type triSurfaceMesh; name bed; }}
    tube.stl {{ type triSurfaceMesh; name tube; }}
}}
castellatedMeshControls
{{
    maxLocalCells 3000000;
    maxGlobalCells 6000000;
    minRefinementCells 0;
    maxLoadUnbalance 0.10;
    nCellsBetweenLevels 2;
    features ();
    refinementSurfaces
    {{
        bed  {{ level ({lvl} {lvl + 1}); patchInfo {{ type wall; }} }}
        tube {{ level ({lvl} {lvl}); patchInfo {{ type wall; }} }}
    }}
    resolveFeatureAngle 30;
    refinementRegions {{}}
    locationInMesh ({0.113 * R} {0.071 * R} {0.5 * zlo});
    allowFreeStandingZoneFaces true;
}}
snapControls
{{
    nSmoothPatch 3;
    tolerance 2.0;
    nSolveIter 50;
    nRelaxIter 5;
    nFeatureSnapIter 10;
    implicitFeatureSnap true;
    explicitFeatureSnap false;
    multiRegionFeatureSnap false;
}}
addLayersControls
{{
    relativeSizes true;
    layers {{}}
    expansionRatio 1.0;
    finalLayerThickness 0.3;
    minThickness 0.1;
    nGrow 0;
    featureAngle 60;
    nRelaxIter 3;
    nSmoothSurfaceNormals 1;
    nSmoothNormals 3;
    nSmoothThickness 10;
    maxFaceThicknessRatio 0.5;
    maxThicknessToMedialRatio 0.3;
    minMedialAxisAngle 90;
    nBufferCellsNoExtrude 0;
    nLayerIter 50;
}}
meshQualityControls
{{
    #includeEtc "caseDicts/meshQualityDict"
    nSmoothScale 4;
    errorReduction 0.75;
}}
mergeTolerance 1e-6;
""")

    def plane(name, z):
        return f"""
    {name}
    {{
        type            surfaceFieldValue;
        libs            ("libfieldFunctionObjects.so");
        regionType      sampledSurface;
        name            {name};
        sampledSurfaceDict
        {{
            type        cuttingPlane;
            planeType   pointAndNormal;
            pointAndNormalDict {{ point (0 0 {z}); normal (0 0 1); }}
            interpolate false;
        }}
        operation       areaAverage;
        fields          (p);
        writeFields     false;
        writeControl    timeStep;
        writeInterval   10;
        log             false;
    }}"""

    write(case, "system/controlDict", "dictionary", "controlDict", f"""
application     simpleFoam;
startFrom       startTime;
startTime       0;
stopAt          endTime;
endTime         {a.iterations};
deltaT          1;
writeControl    timeStep;
writeInterval   {a.iterations};
purgeWrite      0;
writeFormat     ascii;
writePrecision  10;
writeCompression off;
timeFormat      general;
timePrecision   6;
runTimeModifiable false;
functions
{{{plane("planeBottom", 0.0)}{plane("planeTop", H)}
    inletFlux
    {{
        type            surfaceFieldValue;
        libs            ("libfieldFunctionObjects.so");
        regionType      patch;
        name            inlet;
        operation       sum;
        fields          (phi);
        writeFields     false;
        writeControl    timeStep;
        writeInterval   10;
        log             false;
    }}
    outletFlux
    {{
        $inletFlux;
        name            outlet;
    }}
}}
""")
    write(case, "system/fvSchemes", "dictionary", "fvSchemes", """
ddtSchemes { default steadyState; }
gradSchemes { default Gauss linear; }
divSchemes
{
    default none;
    div(phi,U) bounded Gauss linear;
    div((nuEff*dev2(T(grad(U))))) Gauss linear;
}
laplacianSchemes { default Gauss linear limited corrected 0.5; }
interpolationSchemes { default linear; }
snGradSchemes { default limited corrected 0.5; }
""")
    write(case, "system/fvSolution", "dictionary", "fvSolution", """
solvers
{
    p { solver GAMG; smoother GaussSeidel; tolerance 1e-9; relTol 0.02; }
    U { solver smoothSolver; smoother symGaussSeidel; tolerance 1e-10; relTol 0.05; }
}
SIMPLE
{
    nNonOrthogonalCorrectors 1;
    consistent yes;
    residualControl { p 1e-6; U 1e-7; }
}
relaxationFactors { equations { U 0.9; } }
""")
    write(case, "constant/transportProperties", "dictionary", "transportProperties", f"""
transportModel Newtonian;
nu {a.nu_mm2_s};
""")
    write(case, "constant/turbulenceProperties", "dictionary", "turbulenceProperties", """
simulationType laminar;
""")
    walls = """    bed     { type noSlip; }
    tube    { type noSlip; }
    outside { type noSlip; }"""
    write(case, "0/U", "volVectorField", "U", f"""
dimensions [0 1 -1 0 0 0 0];
internalField uniform (0 0 0);
boundaryField
{{
    inlet   {{ type fixedValue; value uniform (0 0 {a.velocity_mm_s}); }}
    outlet  {{ type zeroGradient; }}
{walls}
}}
""")
    pwalls = """    bed     { type zeroGradient; }
    tube    { type zeroGradient; }
    outside { type zeroGradient; }"""
    write(case, "0/p", "volScalarField", "p", f"""
dimensions [0 2 -2 0 0 0 0];
internalField uniform 0;
boundaryField
{{
    inlet   {{ type zeroGradient; }}
    outlet  {{ type fixedValue; value uniform 0; }}
{pwalls}
}}
""")
    print(f"case {case}: background {nxy} x {nxy} x {nz} cells of {a.cell_mm} mm, "
          f"surface level {lvl} (bed features {lvl + 1}), z {zlo} .. {zhi} mm")


if __name__ == "__main__":
    main()
