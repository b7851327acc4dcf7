"""Shared, dependency-light core: vehicle parameters, scenes and frame conventions (numpy only)."""

from uvms.params import ParamError, UVMSParams, load_params
from uvms.scene import Scene, load_scene

__all__ = ["ParamError", "Scene", "UVMSParams", "load_params", "load_scene"]
