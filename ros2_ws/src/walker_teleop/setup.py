"""Install walker_teleop: walkerctl, the walker's command-line tool for operators."""

from setuptools import find_packages, setup

package_name = 'walker_teleop'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='walker maintainers',
    maintainer_email='maintainers@walker-robot.org',
    description='walkerctl: drive a running walker from the command line.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'walkerctl = walker_teleop.walkerctl:main',
    ]},
)
