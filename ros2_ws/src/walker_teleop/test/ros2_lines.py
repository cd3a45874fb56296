"""Read ``ros2 service call`` / ``ros2 action send_goal`` lines and build their messages.

The ros2 command line fills a request from YAML with ``rosidl_runtime_py.set_message_fields``;
this is the same for the plain fields walker's interfaces use, so a documented line whose YAML
names a field that does not exist, or gives a value of the wrong type, fails here.
"""

import importlib
import re
import shlex

import yaml

#: ``ros2 service call NAME TYPE "YAML"`` or ``ros2 action send_goal [--feedback] NAME TYPE ...``
LINE = re.compile(r'ros2 (service call|action send_goal(?: --feedback)?) (\S+) (\S+)(?: (.*))?$')


def interface(type_name: str):
    """Return the class of ``pkg/srv/Name`` or ``pkg/action/Name``."""
    package, kind, name = type_name.split('/')
    return getattr(importlib.import_module(f'{package}.{kind}'), name)


def fill(message, values: dict):
    """Set ``message``'s fields from ``values`` as ``ros2`` does; raise on an unknown field."""
    fields = message.get_fields_and_field_types()
    for key, value in (values or {}).items():
        if key not in fields:
            raise AttributeError(f'{type(message).__name__} has no field {key!r} '
                                 f'(fields: {", ".join(fields)})')
        current = getattr(message, key)
        if hasattr(current, 'get_fields_and_field_types'):
            fill(current, value)
        else:
            setattr(message, key, value)
    return message


def build(line: str):
    """Return (kind, name, message) of one documented ``ros2`` line."""
    match = LINE.search(line.strip())
    assert match, f'not a ros2 service call or action send_goal line: {line!r}'
    kind, name, type_name, rest = match.groups()
    values = yaml.safe_load(shlex.split(rest)[0]) if rest else {}
    cls = interface(type_name)
    # check_fields: the generated setters check each value's type, size and range
    message = (cls.Request if kind == 'service call' else cls.Goal)(check_fields=True)
    return kind.split()[0], name, fill(message, values)


def lines_in(text: str) -> list[str]:
    """Every ``ros2 service call`` and ``ros2 action send_goal`` line of a text."""
    return [line.strip() for line in text.splitlines()
            if line.strip().startswith(('ros2 service call ', 'ros2 action send_goal '))]
