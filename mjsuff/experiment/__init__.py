"""The experiment: scenario files, the loop of one replicate, and the run of many.

* ``scenario`` — TOML scenario files, validated into a typed ``Scenario``; ``shipped_scenarios``,
  the ones shipped with mjsuff.
* ``replicate`` — one replicate of the loop (paper Alg. 1): demos, posterior, bounds, rules.
* ``selection`` — active selection of the next demo's start (paper Eq. 13).
* ``calibration`` — fitting the likelihood's β to a scenario's demonstrator.
* ``coverage`` — whether the bound keeps its confidence against a reference posterior.
* ``measures`` — the dependent measures (paper §4.3) from the per-step table.
* ``runner``, ``backends``, ``results`` — every replicate of a run, where they run, the run
  directory.

Nothing is imported here: importing a submodule must not pull in the others.
"""
