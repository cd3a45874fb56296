"""walker_headless: the walker's cores in one lock-step loop, in one process, without ROS.

The graph is the product for operators; this is the fast path for tests, tuning and
campaigns, and it runs the same code: the plant core, the five joint controller cores, the
planner core and the supervisor's walk runner, composed by calls (:mod:`~walker_headless.loop`,
:mod:`~walker_headless.planner`, :mod:`~walker_headless.shell`), a walk at a time
(:func:`~walker_headless.runner.walk`), recorded into the same bag
(:mod:`~walker_headless.recording`); ``run_all.py --headless`` and campaigns run it through
the walk session (:mod:`walker_bringup.session`).
"""
