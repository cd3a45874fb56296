"""walker_report: the report of a recorded walk, from its rosbag2 bag.

The ROS-free part lives in :mod:`walker_report.core`: reading the bag into arrays
(:mod:`~walker_report.core.walk_data`), the computations (:mod:`~walker_report.core.analysis`),
the figures (:mod:`~walker_report.core.figures`), the animation
(:mod:`~walker_report.core.animation`), the Markdown (:mod:`~walker_report.core.markdown`), the
per-step table shared with walker_bringup (:mod:`~walker_report.core.steps`) and the whole job
(:mod:`~walker_report.core.report`). :mod:`walker_report.walk_report` is the command line and
:mod:`walker_report.progress` its progress line.
"""
