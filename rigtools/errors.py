"""Errors a user can cause. The CLI turns them into one line and an exit status."""


class UserError(Exception):
    """Bad input from the user (config, command line, file). Exit status 2 by default."""

    exit_code = 2


class ConfigError(UserError):
    """A rig file that does not validate."""


class HardwareUnavailable(UserError):
    """Hardware or its driver is not present on this machine."""

    exit_code = 3
