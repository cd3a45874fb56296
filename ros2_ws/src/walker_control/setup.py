"""Install walker_control: Per-joint controllers of the walker (paper sections 2-4)."""

from setuptools import find_packages, setup

package_name = 'walker_control'

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
    description='Per-joint controllers of the walker (paper sections 2-4).',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'joint_controller_node = walker_control.joint_controller_node:main',
        'joint_controllers_node = walker_control.joint_controllers_node:main',
        'control_analysis = walker_control.analysis.command:main',
    ]},
)
