"""A simulated arm with a true geometry of its own, and a simulated operator.

The host side of ``aacmm sim --truth`` and ``aacmm sim --scenario``
(docs/simulator.md): a pure library, no argparse and no printing.

* :mod:`aacmm.simulation.truth` -- :class:`~aacmm.simulation.truth.Truth` (the
  arm's real geometry and error sources), its file (``aacmm-truth-1``),
  :func:`~aacmm.simulation.truth.random_truth` (the sizes:
  :mod:`aacmm.simulation.perturb`); for an arm model
  :func:`~aacmm.simulation.truth.model_truth`;
* :mod:`aacmm.simulation.truthspec` -- ``--truth SPEC``:
  :func:`~aacmm.simulation.truthspec.parse_truth`,
  :func:`~aacmm.simulation.truthspec.parse_model_truth` (``aacmm sim --model``) and
  :func:`~aacmm.simulation.truthspec.check_truth_model`;
* :mod:`aacmm.simulation.encgrade` -- encoder grades (``--encoder-grade``): the
  harmonics of the true encoders' reading errors;
* :mod:`aacmm.simulation.truthcheck` -- lengths across the reach measured
  through the true encoders against the truth (``aacmm demo --check``'s
  evaluation; the tests' studies of calibrations use it too);
* :mod:`aacmm.simulation.thermal` -- a truth's thermal profile and its true
  points at link temperatures;
* :mod:`aacmm.simulation.ik` -- inverse kinematics on the core (damped least
  squares on the Jacobian's theta columns), the arm's joint limits;
* :mod:`aacmm.simulation.articulation` -- articulations spread the way
  calibration and ISO 10360-12 practice ask;
* :mod:`aacmm.simulation.scenario` -- a plan's articulations
  (:func:`~aacmm.simulation.scenario.choreograph`,
  :func:`~aacmm.simulation.scenario.plan_poses`);
* :mod:`aacmm.simulation.operator` -- moving the true arm and pressing buttons;
* :mod:`aacmm.simulation.run` -- performing a plan in step with a capture
  client, or wandering;
* :mod:`aacmm.simulation.control` -- the client of ``aacmm-sim --control``;
* :mod:`aacmm.simulation.process` -- ``aacmm-sim`` as a child process
  (:class:`~aacmm.simulation.process.SimProcess`) and the rendezvous file of
  a running ``aacmm sim``.

Analysis code never imports the truth: only tests compare results with it.

Errors (all :class:`aacmm.errors.AacmmError`):
:class:`~aacmm.simulation.truth.TruthError` (a truth file, also
``ValueError``), :class:`~aacmm.simulation.encgrade.EncoderGradeError` (an
unknown grade, also ``ValueError``), :class:`~aacmm.simulation.scenario.ScenarioError` (a
scenario, also ``ValueError``), :class:`~aacmm.simulation.control.ControlError`
(the control channel failed), :class:`~aacmm.simulation.operator.Stopped` (the
operator was stopped), :class:`~aacmm.simulation.process.SimulatorError` (an
:class:`aacmm.errors.InitError`: the simulator did not start) and
:class:`~aacmm.simulation.process.SimulatorUsageError` (it refused its
options, also ``ValueError``).
"""
