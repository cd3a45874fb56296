#!/usr/bin/env python3
"""Idempotent set-up of walker's environment, used by both README commands.

What it does, each step skipped when its inputs have not changed since the last run:

1. create the virtual environment ``.venv`` (Python 3.11: the ROS 2 Jazzy wheels are cp311);
2. install ``requirements.txt`` under ``constraints.txt`` (every version pinned);
3. rewrite the build-machine paths that the ROS wheels' exported CMake files name
   (``/opt/python/cp311-cp311/...``) to this interpreter's include directories;
4. ``colcon build --symlink-install`` the workspace ``ros2_ws`` (only when a file that the
   build depends on changed: package manifests, setup files, interfaces, data files);
5. return the environment every process of the project runs in: the venv plays the role of
   ``/opt/ros/jazzy`` (underlay), the workspace install is the overlay, and DDS discovery is kept
   on loopback (``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``).

Only the standard library is used here: this runs before anything is installed.

Command line: ``python3 scripts/walker_env.py`` sets up and prints what it did;
``--force`` redoes every step; ``--relock`` regenerates ``constraints.txt`` in a scratch venv;
``--print-env`` prints the environment as shell ``export`` lines.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

__all__ = [
    'REPO_ROOT', 'VENV_DIR', 'WORKSPACE_DIR', 'STAND_IN_PACKAGES', 'SetupError',
    'ensure_environment', 'reexec_in_environment', 'underlay_provides', 'sync_stand_ins',
]

REPO_ROOT = Path(__file__).resolve().parents[1]
VENV_DIR = REPO_ROOT / '.venv'
WORKSPACE_DIR = REPO_ROOT / 'ros2_ws'
REQUIREMENTS = REPO_ROOT / 'requirements.txt'
CONSTRAINTS = REPO_ROOT / 'constraints.txt'
REQUIRED_PYTHON = (3, 11)

_REQUIREMENTS_STAMP = VENV_DIR / '.walker-requirements.sha256'
_BUILD_STAMP = WORKSPACE_DIR / 'install' / '.walker-build.sha256'
_ENV_CACHE = WORKSPACE_DIR / 'install' / '.walker-env.json'
_BUILD_LOG = WORKSPACE_DIR / 'log' / 'walker-build.log'
_WHEEL_BUILD_PREFIX = '/opt/python/cp311-cp311'
_READY_MARKER = 'WALKER_ENV_READY'
#: Workspace packages that stand in for a ROS install's own (same name, same definitions):
#: built only where no prefix of the underlay provides the package already.
STAND_IN_PACKAGES = ('tf2_msgs',)
_STAND_IN_IGNORE = ("COLCON_IGNORE: this package stands in for the underlay's own, which "
                    'provides it here (scripts/walker_env.py writes and removes this file)\n')
# Path-like variables that sourcing the workspace extends.
_PATH_VARIABLES = ('PATH', 'PYTHONPATH', 'AMENT_PREFIX_PATH', 'CMAKE_PREFIX_PATH',
                   'LD_LIBRARY_PATH', 'COLCON_PREFIX_PATH', 'PKG_CONFIG_PATH')


class SetupError(RuntimeError):
    """A set-up step failed; the message says which and where its log is."""


def _say(message: str, quiet: bool) -> None:
    if not quiet:
        print(f'[walker setup] {message}', flush=True)


def _sha256(*parts: bytes) -> str:
    digest = hashlib.sha256()
    for part in parts:
        digest.update(len(part).to_bytes(8, 'little'))
        digest.update(part)
    return digest.hexdigest()


def _venv_python() -> Path:
    return VENV_DIR / 'bin' / 'python'


def _check_interpreter() -> None:
    if sys.version_info[:2] != REQUIRED_PYTHON:
        wanted = '.'.join(map(str, REQUIRED_PYTHON))
        raise SetupError(
            f'walker needs CPython {wanted} (the ROS 2 Jazzy wheels on the package index are '
            f'built for it); this is {sys.version.split()[0]} at {sys.executable}. '
            f'Run the command with python{wanted}.')


def _run(cmd: list[str], *, env: dict[str, str] | None = None, log: Path | None = None,
         what: str) -> None:
    """Run a command; on failure raise SetupError with the tail of its output."""
    if log is not None:
        log.parent.mkdir(parents=True, exist_ok=True)
    result = subprocess.run(cmd, env=env, cwd=REPO_ROOT, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True)
    if log is not None:
        log.write_text(result.stdout)
    if result.returncode != 0:
        tail = '\n'.join(result.stdout.splitlines()[-40:])
        where = f' (full log: {log})' if log is not None else ''
        raise SetupError(f'{what} failed with exit code {result.returncode}{where}:\n{tail}')


def _requirements_digest() -> str:
    return _sha256(REQUIREMENTS.read_bytes(), CONSTRAINTS.read_bytes(),
                   sys.version.encode())


def _ensure_venv(force: bool, quiet: bool) -> bool:
    """Create the venv and install the pinned requirements; return True if anything changed."""
    changed = False
    if force and VENV_DIR.exists():
        shutil.rmtree(VENV_DIR)
    if not _venv_python().exists():
        _say(f'creating the virtual environment {VENV_DIR.relative_to(REPO_ROOT)}', quiet)
        _run([sys.executable, '-m', 'venv', str(VENV_DIR)], what='creating the venv')
        changed = True
    digest = _requirements_digest()
    if _REQUIREMENTS_STAMP.exists() and _REQUIREMENTS_STAMP.read_text().strip() == digest:
        return changed
    _say('installing pinned dependencies (ROS 2 Jazzy wheels, numpy, scipy, pybullet, ...); '
         'the first time this takes a minute or two', quiet)
    started = time.monotonic()
    _run([str(_venv_python()), '-m', 'pip', 'install', '--disable-pip-version-check',
          '-r', str(REQUIREMENTS), '-c', str(CONSTRAINTS)],
         log=VENV_DIR / 'walker-pip.log', what='pip install of requirements.txt')
    _REQUIREMENTS_STAMP.write_text(digest + '\n')
    _say(f'dependencies installed in {time.monotonic() - started:.0f} s', quiet)
    return True


def _python_paths() -> tuple[str, str]:
    """Return (Python include dir, numpy include dir) of the venv's interpreter."""
    code = ('import sysconfig, numpy; '
            "print(sysconfig.get_paths()['include']); print(numpy.get_include())")
    out = subprocess.run([str(_venv_python()), '-c', code], check=True, text=True,
                         stdout=subprocess.PIPE).stdout.split('\n')
    return out[0].strip(), out[1].strip()


def _fix_wheel_cmake_paths(quiet: bool) -> int:
    """Point the wheels' exported CMake files at this machine's include directories.

    Returns the number of files rewritten (0 when they are already right).
    """
    cmake_files = [p for p in (VENV_DIR / 'share').glob('*/cmake/*.cmake')
                   if _WHEEL_BUILD_PREFIX in p.read_text(errors='replace')]
    if not cmake_files:
        return 0
    python_include, numpy_include = _python_paths()
    numpy_pattern = re.compile(re.escape(_WHEEL_BUILD_PREFIX)
                               + r'/lib/python3\.\d+/site-packages/numpy/_core/include')
    python_pattern = re.compile(re.escape(_WHEEL_BUILD_PREFIX) + r'/include/python3\.\d+')
    for path in cmake_files:
        text = numpy_pattern.sub(numpy_include, path.read_text())
        text = python_pattern.sub(python_include, text)
        path.write_text(text)
    _say(f'rewrote build-machine paths in {len(cmake_files)} CMake files of the ROS wheels',
         quiet)
    return len(cmake_files)


def _workspace_digest(requirements_digest: str) -> str:
    """Digest of everything a colcon build of ros2_ws depends on.

    The Python packages are installed with ``--symlink-install``, so editing a module needs no
    rebuild; the list of files is hashed too so that new data files or packages trigger one.
    """
    parts = [requirements_digest.encode()]
    src = WORKSPACE_DIR / 'src'
    for path in sorted(src.rglob('*')):
        if not path.is_file() or '__pycache__' in path.parts:
            continue
        rel = path.relative_to(src).as_posix().encode()
        parts.append(rel)
        if path.suffix != '.py' or path.name == 'setup.py':
            parts.append(path.read_bytes())
    return _sha256(*parts)


def _base_environment() -> dict[str, str]:
    env = dict(os.environ)
    for name in _PATH_VARIABLES + ('COLCON_CURRENT_PREFIX', 'AMENT_CURRENT_PREFIX'):
        env.pop(name, None)
    env['PATH'] = f'{VENV_DIR / "bin"}{os.pathsep}{os.environ.get("PATH", "/usr/bin:/bin")}'
    env['VIRTUAL_ENV'] = str(VENV_DIR)
    env['AMENT_PREFIX_PATH'] = str(VENV_DIR)
    env['CMAKE_PREFIX_PATH'] = str(VENV_DIR)
    # The ROS wheels' libraries: rclpy's extension carries a search path that points outside
    # the environment, and found librcl_action.so (in .venv/lib) and the libraries the wheels
    # vendor (libtinyxml2-*, libssl-*, ... in site-packages/ros_*.libs) only through the search
    # paths of libraries already loaded, so whether `import rclpy` worked depended on what was
    # loaded first (three fresh-clone test runs failed to import it while collecting)
    vendored = sorted(str(p) for p in VENV_DIR.glob('lib/python3*/site-packages/ros_*.libs'))
    env['LD_LIBRARY_PATH'] = os.pathsep.join([str(VENV_DIR / 'lib'), *vendored])
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env['RMW_IMPLEMENTATION'] = 'rmw_fastrtps_cpp'
    env['PYTHONWARNINGS'] = 'ignore::DeprecationWarning'
    return env


def underlay_provides(package: str, prefixes: list[str] | tuple[str, ...]) -> bool:
    """Tell whether an install prefix registers ``package`` in its ament index."""
    return any((Path(prefix) / 'share' / 'ament_index' / 'resource_index' / 'packages'
                / package).is_file() for prefix in prefixes)


def sync_stand_ins(prefixes: list[str] | tuple[str, ...], workspace: Path = WORKSPACE_DIR,
                   quiet: bool = True) -> dict[str, bool]:
    """Skip each stand-in package the underlay provides, build it where it does not.

    A ``COLCON_IGNORE`` file in the package's source directory makes colcon skip it; where
    the file is written, what an earlier build installed of the package is removed too, so
    that the overlay does not shadow the underlay's own. Returns, per stand-in package,
    whether the workspace builds it.
    """
    built = {}
    for package in STAND_IN_PACKAGES:
        source = workspace / 'src' / package
        ignore = source / 'COLCON_IGNORE'
        provided = underlay_provides(package, prefixes)
        if provided and source.is_dir() and not ignore.exists():
            ignore.write_text(_STAND_IN_IGNORE)
            for stale in (workspace / 'build' / package, workspace / 'install' / package):
                shutil.rmtree(stale, ignore_errors=True)
            _say(f'{package}: the underlay provides it; the workspace copy is skipped', quiet)
        elif not provided and ignore.exists():
            ignore.unlink()
            _say(f'{package}: not in the underlay; building the workspace copy', quiet)
        built[package] = source.is_dir() and not provided
    return built


def _build_workspace(force: bool, quiet: bool, requirements_digest: str) -> bool:
    sync_stand_ins(_base_environment()['AMENT_PREFIX_PATH'].split(os.pathsep), quiet=quiet)
    digest = _workspace_digest(requirements_digest)
    if (not force and _BUILD_STAMP.exists() and _ENV_CACHE.exists()
            and _BUILD_STAMP.read_text().strip() == digest):
        return False
    _say('building the ROS 2 workspace ros2_ws with colcon', quiet)
    started = time.monotonic()
    env = _base_environment()
    if force:
        for sub in ('build', 'install'):
            shutil.rmtree(WORKSPACE_DIR / sub, ignore_errors=True)
    _run([str(VENV_DIR / 'bin' / 'colcon'), '--log-base', str(WORKSPACE_DIR / 'log'),
          'build', '--base-paths', str(WORKSPACE_DIR / 'src'),
          '--build-base', str(WORKSPACE_DIR / 'build'),
          '--install-base', str(WORKSPACE_DIR / 'install'),
          '--symlink-install', '--event-handlers', 'console_direct-',
          '--cmake-args', f'-DPython3_EXECUTABLE={_venv_python()}', '-DBUILD_TESTING=OFF'],
         env=env, log=_BUILD_LOG, what='colcon build of ros2_ws')
    _ENV_CACHE.write_text(json.dumps(_sourced_additions(env), indent=1))
    _BUILD_STAMP.write_text(digest + '\n')
    _say(f'workspace built in {time.monotonic() - started:.0f} s', quiet)
    return True


def _sourced_additions(base: dict[str, str]) -> dict[str, object]:
    """Source install/setup.bash once and keep what it adds, to replay it without bash."""
    setup = WORKSPACE_DIR / 'install' / 'setup.bash'
    dump = subprocess.run(['bash', '-c', f'source {shlex.quote(str(setup))} && env -0'],
                          env=base, check=True, stdout=subprocess.PIPE).stdout
    sourced = dict(item.split('=', 1) for item in dump.decode().split('\0') if '=' in item)
    paths: dict[str, list[str]] = {}
    for name in _PATH_VARIABLES:
        before = [p for p in base.get(name, '').split(os.pathsep) if p]
        after = [p for p in sourced.get(name, '').split(os.pathsep) if p]
        paths[name] = [p for p in after if p not in before]
    scalars = {k: v for k, v in sourced.items()
               if k not in _PATH_VARIABLES and base.get(k) != v and k not in ('_', 'SHLVL', 'PWD')}
    return {'prepend': paths, 'set': scalars}


def _runtime_environment() -> dict[str, str]:
    env = _base_environment()
    cache = json.loads(_ENV_CACHE.read_text())
    for name, entries in cache['prepend'].items():
        current = [p for p in env.get(name, '').split(os.pathsep) if p]
        env[name] = os.pathsep.join(entries + [p for p in current if p not in entries])
    env.update(cache['set'])
    env[_READY_MARKER] = '1'
    return env


def ensure_environment(*, force: bool = False, quiet: bool = False) -> dict[str, str]:
    """Set up whatever is missing and return the environment to run the project in.

    Parameters
    ----------
    force : bool
        Redo every step even if its stamp says it is current.
    quiet : bool
        Print nothing unless a step fails.

    Returns
    -------
    dict of str to str
        ``os.environ`` extended with the venv (underlay), the workspace (overlay), loopback-only
        DDS discovery and Fast DDS as the RMW.

    Raises
    ------
    SetupError
        If a step fails; the message names the step and its log file.
    """
    _check_interpreter()
    _ensure_venv(force, quiet)
    _fix_wheel_cmake_paths(quiet)
    _build_workspace(force, quiet, _requirements_digest())
    return _runtime_environment()


def reexec_in_environment(script: str, argv: list[str], *, quiet: bool = False) -> None:
    """Make sure the environment is set up, then re-run ``script`` inside it.

    Returns (doing nothing) when already running inside the prepared environment.
    """
    if os.environ.get(_READY_MARKER) == '1' and Path(sys.prefix) == VENV_DIR:
        return
    try:
        env = ensure_environment(quiet=quiet)
    except SetupError as error:
        print(f'[walker setup] error: {error}', file=sys.stderr)
        raise SystemExit(2) from None
    python = str(_venv_python())
    os.execve(python, [python, script, *argv], env)


def _relock() -> None:
    """Install requirements.txt into a scratch venv and pin everything it installed."""
    with tempfile.TemporaryDirectory() as scratch:
        venv = Path(scratch) / 'venv'
        subprocess.run([sys.executable, '-m', 'venv', str(venv)], check=True)
        result = subprocess.run([str(venv / 'bin' / 'python'), '-m', 'pip', 'install',
                                 '--disable-pip-version-check', '-r', str(REQUIREMENTS)],
                                check=True, text=True, stdout=subprocess.PIPE)
    line = next(x for x in result.stdout.splitlines() if x.startswith('Successfully installed'))
    pins = []
    for token in line.split()[2:]:
        name, version = re.match(r'(.+)-([0-9][^-]*)$', token).groups()
        pins.append(f'{name}=={version}')
    header = ('# Every package the set-up installs, pinned '
              '(generated by `python3 scripts/walker_env.py --relock`).\n')
    CONSTRAINTS.write_text(header + '\n'.join(sorted(pins, key=str.lower)) + '\n')
    print(f'wrote {len(pins)} pins to {CONSTRAINTS}')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--force', action='store_true', help='redo every step')
    parser.add_argument('--relock', action='store_true',
                        help='regenerate constraints.txt from requirements.txt')
    parser.add_argument('--print-env', action='store_true',
                        help='print the runtime environment as shell export lines')
    args = parser.parse_args()
    if args.relock:
        _relock()
        return 0
    started = time.monotonic()
    try:
        env = ensure_environment(force=args.force, quiet=args.print_env)
    except SetupError as error:
        print(f'[walker setup] error: {error}', file=sys.stderr)
        return 2
    if args.print_env:
        for name in sorted(env):
            if env[name] != os.environ.get(name):
                print(f'export {name}={shlex.quote(env[name])}')
    else:
        print(f'[walker setup] environment ready ({time.monotonic() - started:.1f} s)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
