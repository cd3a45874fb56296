"""``bag_info``: print a ``ros2 bag info``-like summary of a bag, or recover a cut one.

Usage: ``bag_info <bag directory> [--recover [DESTINATION]]``. The summary comes from the
bag's ``metadata.yaml``, as ``ros2 bag info`` reads it; for a bag whose recorder was killed it
describes what was flushed before the kill. ``--recover`` writes a complete copy of such a bag
(default ``<bag>_recovered``) that every reader opens.
"""

from __future__ import annotations

import argparse
import datetime
import sys
from pathlib import Path

from walker_bag.core.bag_metadata import BagMetadata, read_metadata
from walker_bag.core.bag_recovery import recover_bag
from walker_bag.core.errors import BagError

__all__ = ['format_info', 'main']

_NS_PER_S = 1_000_000_000


def _size(num_bytes: int) -> str:
    for unit in ('B', 'KiB', 'MiB', 'GiB'):
        if num_bytes < 1024 or unit == 'GiB':
            return f'{num_bytes:.1f} {unit}' if unit != 'B' else f'{num_bytes} B'
        num_bytes /= 1024
    return ''


def _time(ns: int) -> str:
    seconds, rest = divmod(ns, _NS_PER_S)
    stamp = datetime.datetime.fromtimestamp(seconds, tz=datetime.UTC)
    return f'{stamp:%b %d %Y %H:%M:%S}.{rest:09d} UTC ({seconds}.{rest:09d})'


def format_info(bag_dir: Path, metadata: BagMetadata) -> str:
    """Return the summary text of a bag, laid out as ``ros2 bag info`` prints it."""
    size = sum((bag_dir / f).stat().st_size for f in metadata.relative_file_paths
               if (bag_dir / f).exists())
    lines = [
        f'Files:             {"  ".join(metadata.relative_file_paths)}',
        f'Bag size:          {_size(size)}',
        f'Storage id:        {metadata.storage_identifier}',
        f'ROS Distro:        {metadata.ros_distro}',
        f'Duration:          {metadata.duration_ns / _NS_PER_S:.9f}s',
    ]
    if metadata.message_count:
        lines += [f'Start:             {_time(metadata.starting_time_ns)}',
                  f'End:               '
                  f'{_time(metadata.starting_time_ns + metadata.duration_ns)}']
    lines.append(f'Messages:          {metadata.message_count}')
    label = 'Topic information: '
    for info in metadata.topics_with_message_count:
        topic = info.topic_metadata
        durability = ','.join(sorted({p.durability for p in topic.offered_qos_profiles}))
        lines.append(f'{label}Topic: {topic.name} | Type: {topic.type} | Count: '
                     f'{info.message_count} | Serialization Format: '
                     f'{topic.serialization_format} | Durability: {durability or "?"}')
        label = ' ' * len(label)
    if not metadata.topics_with_message_count:
        lines.append(f'{label}(no topics)')
    return '\n'.join(lines)


def main(argv: list[str] | None = None) -> int:
    """Print the summary of a bag (or recover it); return the exit code."""
    parser = argparse.ArgumentParser(prog='bag_info', description=__doc__.split('\n\n')[0])
    parser.add_argument('bag', type=Path, help='bag directory')
    parser.add_argument('--recover', nargs='?', const='', default=None, metavar='DESTINATION',
                        help='write a complete copy of a crash-truncated bag '
                             '(default <bag>_recovered)')
    args = parser.parse_args(argv)
    try:
        if args.recover is not None:
            report = recover_bag(args.bag, args.recover or None)
            state = ('the file was complete' if report.complete
                     else f'the file ended early ({report.stopped_at})')
            print(f'recovered {report.message_count} messages into {report.destination}; '
                  f'{state}')
            return 0
        print(format_info(args.bag, read_metadata(args.bag)))
    except BagError as error:
        print(f'bag_info: {error}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
