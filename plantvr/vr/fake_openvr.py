"""A stand-in for the ``openvr`` package (pyopenvr 1.x) for tests and notebooks without a headset.

It mirrors the API surface :class:`plantvr.vr.VRBridge` uses, with the same names, ctypes structures and
return conventions as pyopenvr (``src/openvr/__init__.py``): ``init``/``shutdown``, ``VRSystem()``,
``VRCompositor()``, ``getRecommendedRenderTargetSize``, ``getProjectionMatrix`` (``HmdMatrix44_t``),
``getEyeToHeadTransform`` (``HmdMatrix34_t``), ``waitGetPoses(render, game)`` filling
``TrackedDevicePose_t`` arrays, ``getControllerState`` returning ``(ok, VRControllerState_t)``,
``pollNextEvent``, ``submit(eye, texture, bounds, flags)`` and the ``openvr.error_code`` exceptions.

Use :func:`install` to put it in ``sys.modules['openvr']`` and script it through :data:`runtime`
(a :class:`FakeRuntime`): poses, controller buttons, a per-frame callback, failures. Real users never
import this module.
"""
from __future__ import annotations

import ctypes
import sys
import threading
import time
import types
from collections.abc import Callable

import numpy as np

__all__ = ["FakeRuntime", "install", "make_module", "runtime", "uninstall"]

# -- constants (values as in openvr.h / pyopenvr) ----------------------------------------------------------
VRApplication_Scene = 1
Eye_Left, Eye_Right = 0, 1
TrackingUniverseSeated, TrackingUniverseStanding = 0, 1
k_unMaxTrackedDeviceCount = 64
k_unTrackedDeviceIndex_Hmd = 0
k_unTrackedDeviceIndexInvalid = 0xFFFFFFFF
TrackedDeviceClass_Invalid, TrackedDeviceClass_HMD, TrackedDeviceClass_Controller = 0, 1, 2
TrackedControllerRole_Invalid, TrackedControllerRole_LeftHand, TrackedControllerRole_RightHand = 0, 1, 2
k_EButton_System, k_EButton_ApplicationMenu, k_EButton_Grip = 0, 1, 2
k_EButton_Axis0, k_EButton_Axis1 = 32, 33
k_EButton_SteamVR_Touchpad, k_EButton_SteamVR_Trigger = 32, 33
TextureType_OpenGL = 1
ColorSpace_Auto, ColorSpace_Gamma, ColorSpace_Linear = 0, 1, 2
Submit_Default = 0
VREvent_None = 0
VREvent_TrackedDeviceActivated, VREvent_TrackedDeviceDeactivated = 100, 101
VREvent_Quit = 700
VRInitError_Init_PathRegistryNotFound = 110
VRInitError_Init_HmdNotFound = 108


def ButtonMaskFromId(button_id: int) -> int:
    """Bit of a button in ``ulButtonPressed``/``ulButtonTouched``."""
    return 1 << button_id


# -- ctypes structures (same fields as pyopenvr) ------------------------------------------------------------
class HmdMatrix34_t(ctypes.Structure):
    _fields_ = [("m", (ctypes.c_float * 4) * 3)]


class HmdMatrix44_t(ctypes.Structure):
    _fields_ = [("m", (ctypes.c_float * 4) * 4)]


class HmdVector3_t(ctypes.Structure):
    _fields_ = [("v", ctypes.c_float * 3)]


class TrackedDevicePose_t(ctypes.Structure):
    _fields_ = [("mDeviceToAbsoluteTracking", HmdMatrix34_t), ("vVelocity", HmdVector3_t),
                ("vAngularVelocity", HmdVector3_t), ("eTrackingResult", ctypes.c_int),
                ("bPoseIsValid", ctypes.c_bool), ("bDeviceIsConnected", ctypes.c_bool)]


class VRControllerAxis_t(ctypes.Structure):
    _fields_ = [("x", ctypes.c_float), ("y", ctypes.c_float)]


class VRControllerState_t(ctypes.Structure):
    _fields_ = [("unPacketNum", ctypes.c_uint32), ("ulButtonPressed", ctypes.c_uint64),
                ("ulButtonTouched", ctypes.c_uint64), ("rAxis", VRControllerAxis_t * 5)]


class Texture_t(ctypes.Structure):
    _fields_ = [("handle", ctypes.c_void_p), ("eType", ctypes.c_int), ("eColorSpace", ctypes.c_int)]


class VRTextureBounds_t(ctypes.Structure):
    _fields_ = [("uMin", ctypes.c_float), ("vMin", ctypes.c_float), ("uMax", ctypes.c_float),
                ("vMax", ctypes.c_float)]


class VREvent_t(ctypes.Structure):
    _fields_ = [("eventType", ctypes.c_uint32), ("trackedDeviceIndex", ctypes.c_uint32),
                ("eventAgeSeconds", ctypes.c_float)]


# -- error_code submodule -----------------------------------------------------------------------------------
class OpenVRError(Exception):
    """Base of pyopenvr's exceptions."""


class ErrorCode(OpenVRError):
    def __init__(self, error_value: int, message: str = ""):
        super().__init__(message)
        self.error_value = error_value


class InitError(ErrorCode):
    pass


class InitError_Init_PathRegistryNotFound(InitError):
    pass


class InitError_Init_HmdNotFound(InitError):
    pass


class CompositorError(ErrorCode):
    pass


class CompositorError_DoNotHaveFocus(CompositorError):
    pass


class CompositorError_RequestFailed(CompositorError):
    pass


def _matrix(cls, a: np.ndarray):
    """``a``'s rows (3 or 4 by 4) as an OpenVR matrix struct ``cls``."""
    m = cls()
    for i in range(len(m.m)):
        for j in range(4):
            m.m[i][j] = float(a[i, j])
    return m


def _matrix34(a: np.ndarray) -> HmdMatrix34_t:
    return _matrix(HmdMatrix34_t, a)


def _matrix44(a: np.ndarray) -> HmdMatrix44_t:
    return _matrix(HmdMatrix44_t, a)


def pose_matrix(position=(0.0, 0.0, 0.0), yaw: float = 0.0, pitch: float = 0.0) -> np.ndarray:
    """4x4 pose at ``position`` turned ``yaw`` (about +y) then ``pitch`` (about +x) radians."""
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    rx = np.array([[1, 0, 0], [0, cp, -sp], [0, sp, cp]])
    out = np.eye(4)
    out[:3, :3] = ry @ rx
    out[:3, 3] = position
    return out


class FakeController:
    """Scriptable controller: pose plus button/axis state, read by ``getControllerState``."""

    def __init__(self, index: int, role: int, position):
        self.index, self.role = index, role
        self.pose = pose_matrix(position)
        self.valid = True
        self.trigger = 0.0
        self.grip = False
        self.menu = False
        self.pad = (0.0, 0.0)
        self.pad_touched = False
        self.pad_pressed = False


class FakeRuntime:
    """State of the fake runtime, shared by the module functions.

    Attributes
    ----------
    installed : bool
        False: ``init`` raises the path-registry error of a machine without SteamVR.
    hmd_present : bool
        False: ``init`` raises ``InitError_Init_HmdNotFound``.
    render_size : (int, int)
        What ``getRecommendedRenderTargetSize`` returns (per eye).
    frame_period : float
        Seconds ``waitGetPoses`` blocks, like the compositor's vsync (0: no wait).
    on_frame : callable(frame, runtime) or None
        Called at the start of every ``waitGetPoses`` to animate poses and buttons.
    fail_at_frame : int or None
        ``waitGetPoses`` raises ``CompositorError_RequestFailed`` from this frame on (runtime lost).
    submissions : list of (frame, eye, handle, bounds)
        Every ``submit`` call.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Back to a fresh, installed runtime with a headset and two controllers."""
        self.installed = True
        self.hmd_present = True
        self.initialized = False
        self.init_count = 0
        self.shutdown_count = 0
        self.render_size = (96, 108)
        self.ipd = 0.064
        self.frame_period = 0.0
        self.frame = 0
        self.on_frame: Callable[[int, FakeRuntime], None] | None = None
        self.fail_at_frame: int | None = None
        self.quit_at_frame: int | None = None
        self.hmd_pose = pose_matrix((0.0, 1.6, 0.0))
        self.left = FakeController(1, TrackedControllerRole_LeftHand, (-0.2, 1.1, -0.3))
        self.right = FakeController(2, TrackedControllerRole_RightHand, (0.2, 1.1, -0.3))
        self.submissions: list[tuple[int, int, int, tuple | None]] = []
        self.tracking_space = None
        self._lock = threading.Lock()

    @property
    def controllers(self) -> list[FakeController]:
        return [self.left, self.right]

    def submissions_by_frame(self) -> dict[int, list[int]]:
        """``{frame: [eyes submitted]}``."""
        out: dict[int, list[int]] = {}
        for f, eye, _, _ in list(self.submissions):
            out.setdefault(f, []).append(eye)
        return out


runtime = FakeRuntime()


class IVRSystem:
    """The subset of pyopenvr's ``IVRSystem`` the bridge uses."""

    def getRecommendedRenderTargetSize(self):
        return tuple(runtime.render_size)

    def getProjectionMatrix(self, eEye, fNearZ, fFarZ):
        left, right, top, bottom = self.getProjectionRaw(eEye)
        # OpenVR's ComposeProjection (Direct3D depth range [0, 1])
        idx, idy, q = 1.0 / (right - left), 1.0 / (bottom - top), fFarZ / (fNearZ - fFarZ)
        p = np.array([[2 * idx, 0, (right + left) * idx, 0], [0, 2 * idy, (top + bottom) * idy, 0],
                      [0, 0, q, q * fNearZ], [0, 0, -1, 0]])
        return _matrix44(p)

    def getProjectionRaw(self, eEye):
        # tangents of the half-angles (left, right, top, bottom), as a Vive-like asymmetric frustum
        return (-1.25, 1.05, -1.45, 1.45) if eEye == Eye_Left else (-1.05, 1.25, -1.45, 1.45)

    def getEyeToHeadTransform(self, eEye):
        x = -0.5 * runtime.ipd if eEye == Eye_Left else 0.5 * runtime.ipd
        return _matrix34(pose_matrix((x, 0.0, 0.0)))

    def getTrackedDeviceClass(self, unDeviceIndex):
        if unDeviceIndex == k_unTrackedDeviceIndex_Hmd:
            return TrackedDeviceClass_HMD
        return TrackedDeviceClass_Controller if unDeviceIndex in (1, 2) else TrackedDeviceClass_Invalid

    def getTrackedDeviceIndexForControllerRole(self, unDeviceType):
        for c in runtime.controllers:
            if c.role == unDeviceType:
                return c.index
        return k_unTrackedDeviceIndexInvalid

    def getControllerRoleForTrackedDeviceIndex(self, unDeviceIndex):
        for c in runtime.controllers:
            if c.index == unDeviceIndex:
                return c.role
        return TrackedControllerRole_Invalid

    def getControllerState(self, unControllerDeviceIndex,
                           unControllerStateSize=ctypes.sizeof(VRControllerState_t)):
        state = VRControllerState_t()
        for c in runtime.controllers:
            if c.index == unControllerDeviceIndex:
                pressed = touched = 0
                if c.grip:
                    pressed |= ButtonMaskFromId(k_EButton_Grip)
                if c.menu:
                    pressed |= ButtonMaskFromId(k_EButton_ApplicationMenu)
                if c.pad_pressed:
                    pressed |= ButtonMaskFromId(k_EButton_SteamVR_Touchpad)
                if c.pad_touched:
                    touched |= ButtonMaskFromId(k_EButton_SteamVR_Touchpad)
                if c.trigger >= 0.99:
                    pressed |= ButtonMaskFromId(k_EButton_SteamVR_Trigger)
                state.unPacketNum = runtime.frame
                state.ulButtonPressed, state.ulButtonTouched = pressed, touched
                state.rAxis[0].x, state.rAxis[0].y = c.pad
                state.rAxis[1].x = c.trigger
                return True, state
        return False, state

    def pollNextEvent(self, pEvent):
        if runtime.quit_at_frame is not None and runtime.frame >= runtime.quit_at_frame:
            pEvent.eventType = VREvent_Quit
            runtime.quit_at_frame = None
            return True
        return False


class IVRCompositor:
    """The subset of pyopenvr's ``IVRCompositor`` the bridge uses."""

    def setTrackingSpace(self, eOrigin):
        runtime.tracking_space = eOrigin

    def waitGetPoses(self, renderPoseArray=None, gamePoseArray=None):
        if not runtime.initialized:
            raise OpenVRError("waitGetPoses called before openvr.init")
        if runtime.frame_period:
            time.sleep(runtime.frame_period)
        with runtime._lock:
            runtime.frame += 1
            frame = runtime.frame
        if runtime.fail_at_frame is not None and frame >= runtime.fail_at_frame:
            raise CompositorError_RequestFailed(2, "CompositorError_RequestFailed")
        if runtime.on_frame is not None:
            runtime.on_frame(frame, runtime)
        if renderPoseArray is None:
            renderPoseArray = (TrackedDevicePose_t * k_unMaxTrackedDeviceCount)()
        devices = [(k_unTrackedDeviceIndex_Hmd, runtime.hmd_pose, True)]
        devices += [(c.index, c.pose, c.valid) for c in runtime.controllers]
        for arr in (renderPoseArray, gamePoseArray):
            if arr is None:
                continue
            for i, pose, valid in devices:
                if i < len(arr):
                    arr[i].mDeviceToAbsoluteTracking = _matrix34(pose)
                    arr[i].bPoseIsValid = bool(valid)
                    arr[i].bDeviceIsConnected = True
        return renderPoseArray, gamePoseArray

    def submit(self, eEye, pTexture, pBounds=None, nSubmitFlags=Submit_Default):
        if not runtime.initialized:
            raise OpenVRError("submit called before openvr.init")
        bounds = None if pBounds is None else (pBounds.uMin, pBounds.vMin, pBounds.uMax, pBounds.vMax)
        runtime.submissions.append((runtime.frame, int(eEye), int(pTexture.handle or 0), bounds))


_system = IVRSystem()
_compositor = IVRCompositor()


def init(applicationType, pStartupInfo=None):
    """Like ``openvr.init``: returns the ``IVRSystem`` or raises an ``InitError`` subclass."""
    if not runtime.installed:
        raise InitError_Init_PathRegistryNotFound(
            VRInitError_Init_PathRegistryNotFound,
            "VRInitError_Init_PathRegistryNotFound: Installation path could not be located (110)")
    if not runtime.hmd_present:
        raise InitError_Init_HmdNotFound(VRInitError_Init_HmdNotFound,
                                         "VRInitError_Init_HmdNotFound: Hmd Not Found (108)")
    runtime.initialized = True
    runtime.init_count += 1
    return _system


def shutdown():
    """Like ``openvr.shutdown``."""
    runtime.initialized = False
    runtime.shutdown_count += 1


def VRSystem():
    return _system


def VRCompositor():
    return _compositor


def isRuntimeInstalled():
    return runtime.installed


def isHmdPresent():
    return runtime.hmd_present


def make_module() -> types.ModuleType:
    """A module object named ``openvr`` (with ``openvr.error_code``) exposing this fake."""
    mod = types.ModuleType("openvr")
    src = sys.modules[__name__]
    for name in dir(src):
        if not name.startswith("__"):
            setattr(mod, name, getattr(src, name))
    err = types.ModuleType("openvr.error_code")
    for name in ("OpenVRError", "ErrorCode", "InitError", "InitError_Init_PathRegistryNotFound",
                 "InitError_Init_HmdNotFound", "CompositorError", "CompositorError_DoNotHaveFocus",
                 "CompositorError_RequestFailed"):
        setattr(err, name, getattr(src, name))
    mod.error_code = err
    mod.__file__ = __file__
    mod.FAKE = True
    return mod


def install(reset: bool = True) -> types.ModuleType:
    """Insert the fake as ``sys.modules['openvr']`` (and ``openvr.error_code``); returns the module."""
    if reset:
        runtime.reset()
    mod = make_module()
    sys.modules["openvr"] = mod
    sys.modules["openvr.error_code"] = mod.error_code
    return mod


def uninstall() -> None:
    """Remove the fake from ``sys.modules`` (only if it is the fake)."""
    if getattr(sys.modules.get("openvr"), "FAKE", False):
        del sys.modules["openvr"]
        sys.modules.pop("openvr.error_code", None)
