"""The Foxglove layout shipped with walker_viz, built with the Foxglove SDK's layout types.

``config/walker.foxglove.json`` is this module's output (``python -m walker_viz.foxglove_layout
[namespace] > walker.foxglove.json``); a test checks the file is what it builds. The layout:

* a 3D panel in the ``truss`` frame: the robot from ``robot_description`` moved by TF, the
  transforms, the markers (truss, target node, planned tip path) and the truss map's markers
  (each node surveyed or nominal, its uncertainty ellipsoid);
* below it, each gripper's wrist camera (``camera_<g>/image_raw``, calibrated by
  ``camera_<g>/camera_info``), side by side: the last frame the plant sent (a robot without
  cameras has no such topic, and the panels stay empty);
* a plot of every joint controller's position error [rad] (``controllers/<joint>/state``);
* the step phases as state transitions (``phase``), beside the controllers' mode
  (``control_mode``).
"""

from __future__ import annotations

import json
import sys

import foxglove.layouts as fl
from walker_msgs.msg import ControlMode, StepPhase

from walker_core.joint_roles import GRIPPERS, PHYSICAL_JOINT_NAMES
from walker_viz.core.robot_tree import WORLD_FRAME

__all__ = ['walker_layout', 'layout_json', 'main']

_PHASES = ('IDLE', 'EXTRACTION', 'COARSE', 'FINE', 'INSERTION', 'SAFE_HOLD')
_MODES = ('OFF', 'HOLD', 'COARSE', 'FINE')


def _states(message: type,
            names: tuple[str, ...]) -> fl.StateTransitionsDiscreteCustomStates:
    """Label each constant of ``message`` named in ``names`` (its value) with its name."""
    return fl.StateTransitionsDiscreteCustomStates(states=[
        fl.StateTransitionsDiscreteCustomState(value=str(getattr(message, name)), label=name)
        for name in names])


def _camera(ns: str, gripper: str) -> fl.ImagePanel:
    """Return the Image panel of ``gripper``'s wrist camera in the namespace ``ns``."""
    return fl.ImagePanel(title=f'camera {gripper}', config=fl.ImageConfig(
        image_mode=fl.ImageModeConfig(image_topic=f'{ns}/camera_{gripper}/image_raw',
                                      calibration_topic=f'{ns}/camera_{gripper}/camera_info')))


def walker_layout(namespace: str = '/walker') -> fl.Layout:
    """Build the layout for the walker in ``namespace``."""
    ns = namespace.rstrip('/')
    scene = fl.ThreeDeePanel(title='walker on the truss', config=fl.ThreeDeeConfig(
        fixed_frame=WORLD_FRAME, follow_tf=WORLD_FRAME, follow_mode='follow-none',
        camera_state=fl.ThreeDeeCameraState(distance=2.0, phi=55.0, theta_offset=45.0,
                                            target=(0.4, 0.3, 0.0), perspective=True),
        transforms=fl.BaseRendererTransforms(show_label=False, axis_size=0.05),
        layers={'walker': fl.BaseRendererUrdfLayerSettings(
            layer_id='foxglove.Urdf', instance_id='walker', label='walker',
            source_type='topic', topic=f'{ns}/robot_description',
            control_mode='transforms', display_mode='visual')},
        topics={f'{ns}/{topic}': fl.BaseRendererRosMarkerTopicSettings(visible=True)
                for topic in ('markers', 'truss_map_markers')}))
    errors = fl.PlotPanel(title='joint position errors [rad]', config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=f'{ns}/controllers/{joint}/state.position_error',
                             label=joint, timestamp_method='headerStamp')
               for joint in PHYSICAL_JOINT_NAMES],
        show_legend=True, y_axis_label='rad'))
    phases = fl.StateTransitionsPanel(title='step phase and control mode',
                                      config=fl.StateTransitionsConfig(paths=[
                                          fl.StateTransitionsSeries(
                                              value=f'{ns}/phase.phase', label='phase',
                                              timestamp_method='headerStamp',
                                              custom_states=_states(StepPhase, _PHASES)),
                                          fl.StateTransitionsSeries(
                                              value=f'{ns}/control_mode.mode', label='mode',
                                              timestamp_method='headerStamp',
                                              custom_states=_states(ControlMode, _MODES))]))
    cameras = fl.SplitContainer(direction='row', items=[
        fl.SplitItem(proportion=1, content=_camera(ns, gripper)) for gripper in GRIPPERS])
    return fl.Layout(content=fl.SplitContainer(direction='row', items=[
        fl.SplitItem(proportion=3, content=fl.SplitContainer(direction='column', items=[
            fl.SplitItem(proportion=2, content=scene),
            fl.SplitItem(proportion=1, content=cameras)])),
        fl.SplitItem(proportion=2, content=fl.SplitContainer(direction='column', items=[
            fl.SplitItem(proportion=2, content=errors),
            fl.SplitItem(proportion=1, content=phases)]))]))


def layout_json(namespace: str = '/walker') -> str:
    """Return the layout as the JSON file Foxglove imports (indented, newline-terminated)."""
    return json.dumps(json.loads(walker_layout(namespace).to_json()), indent=2) + '\n'


def main(argv: list[str] | None = None) -> int:
    """Print the layout for the namespace given (default ``/walker``)."""
    argv = sys.argv[1:] if argv is None else argv
    sys.stdout.write(layout_json(argv[0] if argv else '/walker'))
    return 0


if __name__ == '__main__':
    sys.exit(main())
