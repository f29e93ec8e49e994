"""The analytic plane scene as a fixture for the tests of the render in passes."""

from plane_scene import plane  # noqa: F401 (the fixture)
