"""Behaviour fake of interbotix_common_modules/common_robot/exceptions.py (see tests/vendor/backends.py)."""


class InterbotixException(Exception):
    """The toolbox's own error: a second global node, a second startup."""
