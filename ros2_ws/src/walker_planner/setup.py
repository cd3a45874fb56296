"""Install walker_planner: Trajectory planner of the walker (paper section 5)."""

from setuptools import find_packages, setup

package_name = 'walker_planner'

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
    description='Trajectory planner of the walker (paper section 5).',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'planner_node = walker_planner.planner_node:main',
        'planner_figures = walker_planner.figures:main',
    ]},
)
