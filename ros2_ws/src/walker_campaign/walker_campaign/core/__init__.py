"""ROS-free, Ray-free core of walker_campaign: no rclpy or ray import anywhere below here.

Modules: :mod:`~walker_campaign.core.distributions` (uniform, normal, a fixed list),
:mod:`~walker_campaign.core.targets` (parameters addressed by name, element and pattern),
:mod:`~walker_campaign.core.parameter_sets` (the model's and the truth's parameter sets, checked
by the walker's own schema), :mod:`~walker_campaign.core.spec` (the campaign spec),
:mod:`~walker_campaign.core.plan` (each run's parameters from the seed and its index alone),
:mod:`~walker_campaign.core.rows` (a walk's summary as result rows),
:mod:`~walker_campaign.core.results` (the campaign's results file: append, resume),
:mod:`~walker_campaign.core.statistics` (Wilson interval, rank correlations, Pareto front),
:mod:`~walker_campaign.core.report` with :mod:`~walker_campaign.core.figures` (the report),
:mod:`~walker_campaign.core.progress` (the progress line).
"""
