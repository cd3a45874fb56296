"""Install walker_headless: the walker's cores in one lock-step loop, without ROS."""

from setuptools import find_packages, setup

package_name = 'walker_headless'

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
    description='The headless runner: the walker in one lock-step loop, without ROS.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'figure6 = walker_headless.figure6:main',
    ]},
)
