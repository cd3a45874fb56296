"""Install walker_campaign: Monte Carlo and sweep campaigns of walks, on Ray, and their report."""

from glob import glob

from setuptools import find_packages, setup

package_name = 'walker_campaign'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['test']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/config', glob('config/*.yaml')),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='walker maintainers',
    maintainer_email='maintainers@walker-robot.org',
    description='Monte Carlo and sweep campaigns of walks under dispersed parameters, on Ray.',
    license='Apache-2.0',
    entry_points={'console_scripts': [
        'campaign = walker_campaign.campaign:main',
    ]},
)
