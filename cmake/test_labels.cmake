# The ctest label of every test of ssc_tests, by GoogleTest suite, so that a subset runs alone:
# `tools/run-tests -L unit` (docs/architecture.md, Tests). Every test has exactly one label:
#   unit     pure logic, ops and their gradient checks, parsing: a second at most each
#   physics  simulations checked against closed forms, CalculiX or the run's audits
#   cli      runs build/bin/ssc or Chromium (and the catalogue of bad inputs, labelled in CMakeLists.txt)
#   slow     over ~15 s on an idle core (measured times: docs/architecture.md, Tests)
#   gpu      needs a GPU: skipped, or only its CPU part run, without one
# A list holds suites (`Suite`) or single tests (`Suite.Test`); a test's own entry wins over its
# suite's. A suite in no list gets SSC_DEFAULT_TEST_LABEL, and the test `test_labels`
# (cmake/check_test_labels.cmake) fails until it is listed.
set(SSC_TEST_LABELS unit physics cli slow gpu)
set(SSC_DEFAULT_TEST_LABEL unit)

set(SSC_TESTS_unit
  BatchLoop CodegenPlan GalerkinStart CodegenSha256 CodegenSource
  CutCellIntegrals CutCellSphere SurfaceExtraction SurfacePly
  GeometryGridPlacement GeometryMesh GeometryMeshSdf GeometryPrimitives GeometrySdfFile GeometryTransform
  CameraTest DepthPngTest DepthRenderTest ObservationTest
  ImplicitLinearSolve ImplicitPolar ImplicitTrilinear OpAdjointContact OpAdjointElasticity OpAdjointNewmark
  OpAdjointNodal OpAdjointPolar OpAdjointTrilinear OpChecks
  OptimBest OptimConvergence OptimFactory OptimRules OptimStopping ParameterSpaceNames ParameterSpaceTransforms
  ReconstructionStarts LevenbergMarquardt ParameterBounds
  ExtensionTable PlausibleRanges DiagnosisModels DiagnosisNaming SupportedSpan RunRecord WriteErrors MeasurementCorrection SvgPlot
  Layering OutputFolder ParameterNames ParameterTable Pcg BandFactor ElementPacks ReportHtml SceneFiles Units
  NvrtcCache NvrtcCompile ByteRecord BatchWorkers ComputeDevice
  RecordingReaders FrameTiming PlaneFit WorldFrame ScanRegistration MotionEstimate Segmentation ObjectSelection
  GpuForward.ReportsMissingGpuCleanly GpuKernels.GroupsCoverThePlanOnce)

set(SSC_TESTS_physics
  AirDrag CorotationUpdate ExtensionSwitches Friction GradientPipeline HeterogeneousStiffness NeoHookean
  PhysicsBatch PhysicsBounce PhysicsCantilever PhysicsFreeFall PhysicsGrid PhysicsRigidMotion StiffContact
  EnergyAudit MatchCheck RunChecks BatchEvaluation
  ReconstructionEndToEnd ReconstructionFailures ReconstructionLeastSquares
  FrameTimes FrictionSlope GridFrame CalculixFriction CalculixTwoMaterials CalculixInterfaceSearch GoodnessOfFit ParameterSlices PlaneProposals RestingStart TablePoints CalculixDrops PrepareSynthetic PrepareRealRecording
  GpuForward.ExplodingGradientFailsCleanlyOnTheCpu GpuKernels.RandomStateAndEveryAdjointGroupOnTheCpu)

set(SSC_TESTS_cli
  CliSimulate DiagnoseCli ExtensionFit FrictionFit GoodnessOfFitCli Render CalculixDropsFit PrepareCli MpiRanks
  ReportHtml.ChromiumDrawsThePage)

set(SSC_TESTS_slow
  DiagnoseCli.NamesFrictionHiddenInDataFromASmallerTimeStep DiagnoseCli.SaysNoneForCleanDataFromASmallerTimeStep
  DiagnoseCli.AirDragThatNeedsAnImplausibleDensityIsNotNamed DiagnoseCli.NamesTheCameraWhenItsFocalLengthIsOff
  ExtensionFit.AirDragFromAFinerSimulation ExtensionFit.MaterialRegionFromASmallerTimeStep
  ExtensionFit.NeoHookeanYoungsModulusFromASmallerTimeStep ExtensionFit.SecondPlaneFromAFinerSimulation
  FrictionFit.ReconstructRecoversMuFromAFinerSimulation
  NeoHookean.LargeDeflectionCantileverAgainstCalculix CalculixDropsFit.DiagnoseFitsTheDiscretizationControlOnHalfTheCellSize
  CalculixDropsFit.AOneStartFitThatStallsOnARoughCostGoesOnAndIsNotCalledConverged
  CalculixDropsFit.ACylinderDroppedOnTheInclineFitsCalculixsModulus
  PrepareCli.PrepareThenReconstructRecoversYoungsModulus PrepareCli.CalculixDropPreparedThenFittedSlow
  MpiRanks.ReconstructOnTwoRanksGivesTheOneProcessResult
  CalculixInterfaceSearch.FromTheStiffnessGradientFindsCalculixsInterface
  NvrtcCompile.AllExampleKernelsDoubleAndFloat)

set(SSC_TESTS_gpu
  GpuAdjoint GpuDiagnoseCli GpuExtension GpuForward GpuKernels GpuProfile GpuReconstruct)

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
