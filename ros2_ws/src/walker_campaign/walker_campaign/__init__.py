"""walker_campaign: Monte Carlo and sweep campaigns of walks, on Ray, and their report.

:mod:`walker_campaign.core` holds every decision, ROS-free and Ray-free (the spec, the runs'
parameters, the results file, the statistics, the report); :mod:`walker_campaign.walks` runs
one walk (headless, or the sim-time graph) from a run's two parameter files;
:mod:`walker_campaign.ray_runner` is the thin Ray layer; :mod:`walker_campaign.campaign` the
command line (``scripts/campaign.py``).
"""
