"""Install walker_config: the parameter file read once into every section, with every rule."""

from setuptools import find_packages, setup

package_name = 'walker_config'

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
    description='The parameter file read once into every typed section, with every rule '
                'between sections.',
    license='Apache-2.0',
)
