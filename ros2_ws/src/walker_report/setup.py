"""Install walker_report: the walk report (figures, step table, animation) from a bag."""

from setuptools import find_packages, setup

package_name = 'walker_report'

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
    description='The walk report: figures, step table and animation of a recorded walk.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'walk_report = walker_report.walk_report:main',
    ]},
)
