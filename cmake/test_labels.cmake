# The ctest label of every test of ssc_tests, by GoogleTest suite, so that a subset runs alone:
# `tools/run-tests -L unit` (docs/architecture.md, Tests). Every test has exactly one label:
#   unit     pure logic, ops and their gradient checks, parsing: well under a second each
#   physics  simulations checked against closed forms or CalculiX
#   cli      runs build/bin/ssc (or the catalogue of bad inputs, labelled in CMakeLists.txt)
#   slow     over ~20 s
#   gpu      needs a GPU (or NVRTC): skipped, or only its CPU half run, without one
# A list holds suites (`Suite`) or single tests (`Suite.Test`); a test's own entry wins over its
# suite's. A suite in no list gets SSC_DEFAULT_TEST_LABEL, and the test `test_labels`
# (cmake/check_test_labels.cmake) fails until it is listed.
set(SSC_TEST_LABELS unit physics cli slow gpu)
set(SSC_DEFAULT_TEST_LABEL unit)

set(SSC_TESTS_unit
  BatchLoop CodegenPlan CodegenSha256 CodegenSource
  CutCellIntegrals CutCellSphere SurfaceExtraction SurfacePly
  GeometryGridPlacement GeometryMesh GeometryMeshSdf GeometryPrimitives GeometrySdfFile GeometryTransform
  CameraTest DepthPngTest DepthRenderTest ObservationTest
  ImplicitLinearSolve ImplicitPolar ImplicitTrilinear OpAdjointContact OpAdjointElasticity OpAdjointNewmark
  OpAdjointNodal OpAdjointPolar OpAdjointTrilinear OpChecks
  OptimBest OptimConvergence OptimFactory OptimRules OptimStopping ParameterSpaceNames ParameterSpaceTransforms
  ReconstructionStarts
  Layering OutputFolder ParameterNames ParameterTable Pcg ReportHtml SceneFiles Units
  NvrtcCompile.PtxasLogParsing
  GpuForward.ExplodingGradientFailsCleanlyOnTheCpu GpuForward.ReportsMissingGpuCleanly
  GpuKernels.GroupsCoverThePlanOnce)

set(SSC_TESTS_physics
  AirDrag CorotationUpdate ExtensionSwitches Friction GradientPipeline HeterogeneousStiffness NeoHookean
  PhysicsBatch PhysicsBounce PhysicsCantilever PhysicsFreeFall PhysicsGrid PhysicsRigidMotion StiffContact
  EnergyAudit MatchCheck RunChecks
  ReconstructionEndToEnd ReconstructionFailures
  GpuKernels.RandomStateAndEveryAdjointGroupOnTheCpu)

set(SSC_TESTS_cli
  CliSimulate DiagnoseCli ExtensionFit FrictionFit
  ReportHtml.ChromiumDrawsThePage)

set(SSC_TESTS_slow)

set(SSC_TESTS_gpu
  GpuAdjoint GpuExtension GpuForward GpuKernels GpuProfile GpuReconstruct
  NvrtcCache NvrtcCompile)

# Sets `out` to the label listed for `test` (Suite.Test) or its suite, or to "" if neither is listed.
function(ssc_test_label test out)
  string(REGEX REPLACE "\\..*" "" suite "${test}")
  foreach(name IN ITEMS "${test}" "${suite}")
    foreach(label IN LISTS SSC_TEST_LABELS)
      list(FIND SSC_TESTS_${label} "${name}" at)
      if(NOT at EQUAL -1)
        set(${out} ${label} PARENT_SCOPE)
        return()
      endif()
    endforeach()
  endforeach()
  set(${out} "" PARENT_SCOPE)
endfunction()
