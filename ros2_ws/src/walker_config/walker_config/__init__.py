"""walker_config: the walker's configuration, one entry point for whoever runs the whole walker.

:func:`walker_config.core.configuration.load_configuration` reads the parameter file once
into every package's typed section and runs every rule between sections; the node graph's
bring-up, the headless runner and campaigns use it. ROS-free (a package of its own because
it depends on every package that owns a section, and both the bring-up and the headless
runner depend on it).
"""
