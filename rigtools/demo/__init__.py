"""``rig demo``: the paper's study end to end on the simulated rig, its findings judged from data.

:mod:`rigtools.demo.settings` (resolution, operating points), :mod:`rigtools.demo.steps` (one
function per step, plain data out), :mod:`rigtools.demo.findings` (C1-C7 evaluators),
:mod:`rigtools.demo.report` (the HTML report), :mod:`rigtools.demo.run` (:func:`rigtools.demo.run.run_demo`).
"""
