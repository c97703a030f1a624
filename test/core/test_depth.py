"""Tests of walker_gait.core.depth: decoding, Kinect eq. (1), CameraInfo, undistortion, back-projection."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from walker_gait.core.depth import (
    KINECT_INVALID,
    CameraInfoError,
    DepthDecodeError,
    DepthProjector,
    check_info_matches,
    decode_depth,
    intrinsics_from_camera_info,
    kinect_raw_to_metres,
    metres_to_kinect_raw,
)
from walker_gait.core.segmentation import FloorConfig, Segmenter, fit_floor_ransac
from walker_gait.core.types import CameraIntrinsics

REAL_DATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "data" / "real"
INTR = CameraIntrinsics(width=8, height=6, fx=5.0, fy=6.0, cx=3.5, cy=2.5)


def _pad_rows(arr: np.ndarray, pad: int, fill: int = 0xAB) -> tuple[bytes, int]:
    """Serialise a 2-D array row by row with ``pad`` garbage bytes after each row."""
    rows = [r.tobytes() + bytes([fill]) * pad for r in arr]
    return b"".join(rows), arr.shape[1] * arr.itemsize + pad


# --------------------------------------------------------------------------- decoding


@pytest.mark.parametrize("encoding", ["16UC1", "mono16"])
@pytest.mark.parametrize("big", [False, True])
@pytest.mark.parametrize("pad", [0, 3, 64])
def test_decode_16bit_millimetres(encoding: str, big: bool, pad: int) -> None:
    mm = np.array([[0, 1, 500, 1234], [65535, 0, 2000, 7]], dtype=np.uint16)
    data, step = _pad_rows(mm.astype(">u2" if big else "<u2"), pad)
    out = decode_depth(data, encoding=encoding, width=4, height=2, step=step, is_bigendian=big)
    assert out.dtype == np.float32 and out.shape == (2, 4) and out.flags.c_contiguous
    expected = np.where(mm == 0, np.nan, mm * 0.001).astype(np.float32)
    np.testing.assert_allclose(out, expected, rtol=1e-6, equal_nan=True)


@pytest.mark.parametrize("big", [False, True])
@pytest.mark.parametrize("pad", [0, 1, 8])
def test_decode_32fc1_metres_and_invalid(big: bool, pad: int) -> None:
    m = np.array([[1.5, np.nan, np.inf, -np.inf, 999.0], [0.0, -2.0, 3.25, 1e-3, 3e38]], dtype=np.float32)
    data, step = _pad_rows(m.astype(">f4" if big else "<f4"), pad)
    out = decode_depth(data, encoding="32FC1", width=5, height=2, step=step, is_bigendian=big)
    # NaN, +-Inf, <= 0 and absurd (> MAX_DEPTH_M = 1 km) values are invalid
    expected = np.array([[1.5, np.nan, np.nan, np.nan, 999.0], [np.nan, np.nan, 3.25, 1e-3, np.nan]], dtype=np.float32)
    np.testing.assert_array_equal(out, expected)


def test_decode_accepts_bytes_memoryview_bytearray_and_arrays() -> None:
    mm = np.arange(1, 13, dtype="<u2").reshape(3, 4)
    kwargs: dict[str, Any] = {"encoding": "16UC1", "width": 4, "height": 3, "step": 8, "is_bigendian": False}
    ref = decode_depth(mm.tobytes(), **kwargs)
    for data in (memoryview(mm.tobytes()), bytearray(mm.tobytes()), np.frombuffer(mm.tobytes(), np.uint8), mm):
        np.testing.assert_array_equal(decode_depth(data, **kwargs), ref)  # type: ignore[arg-type]
    # the result is a copy: mutating the source does not change it
    src = np.frombuffer(mm.tobytes(), np.uint8).copy()
    out = decode_depth(src, **kwargs)
    src[:] = 0
    assert np.all(np.isfinite(out))


def test_decode_trailing_bytes_and_short_last_row_padding() -> None:
    mm = np.full((2, 3), 1000, dtype="<u2")
    data, step = _pad_rows(mm, 4)
    # last row's padding may be missing; extra trailing bytes are ignored
    out1 = decode_depth(data[:-4], encoding="16UC1", width=3, height=2, step=step, is_bigendian=False)
    out2 = decode_depth(data + b"\x00" * 9, encoding="16UC1", width=3, height=2, step=step, is_bigendian=False)
    np.testing.assert_array_equal(out1, np.ones((2, 3), np.float32))
    np.testing.assert_array_equal(out2, out1)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"encoding": "rgb8"}, "rgb8"),
        ({"encoding": "8UC1"}, "8UC1"),
        ({"encoding": ""}, "unsupported depth encoding"),
        ({"step": 7}, "step 7 is smaller"),
        ({"width": 0}, "must be positive"),
        ({"height": -2}, "must be positive"),
        ({"data": b"\x00" * 15}, "buffer too short"),
        ({"depth_format": "kinect"}, "depth_format"),
        ({"encoding": "32FC1", "step": 16, "depth_format": "kinect_raw", "data": b"\x00" * 32}, "kinect_raw"),
    ],
)
def test_decode_errors_name_the_problem(kwargs: dict[str, Any], match: str) -> None:
    args: dict[str, Any] = {
        "data": b"\x00" * 16,
        "encoding": "16UC1",
        "width": 4,
        "height": 2,
        "step": 8,
        "is_bigendian": False,
    }
    args.update(kwargs)
    with pytest.raises(DepthDecodeError, match=match):
        decode_depth(args.pop("data"), **args)


def test_decode_error_is_value_error() -> None:
    assert issubclass(DepthDecodeError, ValueError)
    assert issubclass(CameraInfoError, ValueError)


# --------------------------------------------------------------------------- Kinect eq. (1)


def test_kinect_equation_values() -> None:
    raw = np.array([0, 500, 1000, 1084, 1100, 2046, 2047, 4000], dtype=np.uint16)
    z = kinect_raw_to_metres(raw)
    np.testing.assert_allclose(z[:3], 1.0 / (-0.00307 * raw[:3].astype(float) + 3.33), rtol=1e-6)
    assert np.all(np.isnan(z[3:]))  # 1084: 471 m (absurd); 1100+: eq. (1) negative; 2047: no reading
    data = raw.astype("<u2").tobytes()
    out = decode_depth(
        data, encoding="16UC1", width=8, height=1, step=16, is_bigendian=False, depth_format="kinect_raw"
    )
    np.testing.assert_array_equal(out[0], z)
    out_be = decode_depth(
        raw.astype(">u2").tobytes(), encoding="mono16", width=8, height=1, step=16, is_bigendian=True,
        depth_format="kinect_raw",
    )
    np.testing.assert_array_equal(out_be, out)


def test_kinect_round_trip() -> None:
    z = np.linspace(0.4, 9.0, 2000)
    raw = metres_to_kinect_raw(z)
    assert raw.dtype == np.uint16 and np.all(raw < KINECT_INVALID)
    back = kinect_raw_to_metres(raw).astype(np.float64)
    step = 0.00307 * z**2  # metres per raw unit at z
    assert np.all(np.abs(back - z) <= 0.5 * step * 1.05 + 1e-6)
    # raw -> metres -> raw is the identity on valid raw values
    r = np.arange(0, 1040, dtype=np.uint16)
    np.testing.assert_array_equal(metres_to_kinect_raw(kinect_raw_to_metres(r)), r)
    # invalid depths map to 2047
    bad = metres_to_kinect_raw(np.array([np.nan, np.inf, -1.0, 0.0, 0.1, 50.0]))
    np.testing.assert_array_equal(bad, KINECT_INVALID)
    # float input to kinect_raw_to_metres
    np.testing.assert_array_equal(
        kinect_raw_to_metres(np.array([500.0, -3.0, np.nan])),
        kinect_raw_to_metres(np.array([500, 2047, 2047], np.uint16)),
    )


# --------------------------------------------------------------------------- hypothesis: decode


ENCODINGS = ["16UC1", "mono16", "32FC1", "rgb8", "8UC1", "16SC1", "bgra8", ""]


@st.composite
def depth_messages(draw: st.DrawFn) -> dict[str, Any]:
    width = draw(st.integers(-2, 12))
    height = draw(st.integers(-2, 10))
    encoding = draw(st.sampled_from(ENCODINGS))
    bpp = 4 if encoding == "32FC1" else 2
    pad = draw(st.integers(-3, 6))
    step = max(0, width) * bpp + pad
    kind = draw(st.sampled_from(["random", "nan", "inf", "zeros", "kinect_invalid", "mixed"]))
    n = max(0, step) * max(0, height)
    n += draw(st.integers(-4, 4))
    n = max(0, n)
    if kind == "random":
        data = draw(st.binary(min_size=n, max_size=n))
    elif kind == "zeros":
        data = b"\x00" * n
    elif kind == "kinect_invalid":
        data = (np.full(n // 2 + 1, 2047, dtype="<u2").tobytes())[:n]
    else:
        vals = {"nan": [np.nan], "inf": [np.inf, -np.inf], "mixed": [np.nan, np.inf, -1.0, 0.0, 1.5, 1e30, 3.0]}[kind]
        arr = np.resize(np.array(vals, dtype="<f4"), n // 4 + 1)
        data = arr.tobytes()[:n]
    return {
        "data": data,
        "encoding": encoding,
        "width": width,
        "height": height,
        "step": step,
        "is_bigendian": draw(st.booleans()),
        "depth_format": draw(st.sampled_from(["auto", "kinect_raw", "auto", "bogus"])),
    }


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(msg=depth_messages(), seed=st.integers(0, 2**31 - 1))
def test_decode_property_only_decode_error_escapes(msg: dict[str, Any], seed: int) -> None:
    data = msg.pop("data")
    try:
        out = decode_depth(data, **msg)
    except DepthDecodeError:
        return
    assert out.shape == (msg["height"], msg["width"]) and out.dtype == np.float32
    finite = out[np.isfinite(out)]
    assert np.all(finite > 0) and not np.any(np.isinf(out))
    # and the segmenter never raises on any decoded frame
    intr = CameraIntrinsics(width=msg["width"], height=msg["height"], fx=3.0, fy=3.0, cx=msg["width"] / 2, cy=0.0)
    pts = DepthProjector(intr).points(out)
    for intrinsics in (None, intr):
        res = Segmenter(rng=np.random.default_rng(seed), intrinsics=intrinsics).process(out, pts)
        assert res.mask.shape == out.shape and res.points.shape == (int(res.mask.sum()), 3)
        assert np.all(np.isfinite(res.points))


# --------------------------------------------------------------------------- CameraInfo

K = [525.0, 0.0, 319.5, 0.0, 526.0, 239.5, 0.0, 0.0, 1.0]
P = [520.0, 0.0, 320.0, 0.0, 0.0, 521.0, 240.0, 0.0, 0.0, 0.0, 1.0, 0.0]
D5 = [0.05, -0.1, 0.001, -0.002, 0.02]
D_STRONG = [-0.28, 0.09, 0.001, -0.002, 0.0]  # barrel distortion of a wide lens


def test_intrinsics_rectified_uses_p() -> None:
    intr, und = intrinsics_from_camera_info(
        width=640, height=480, k=K, d=D5, p=P, distortion_model="plumb_bob", rectified=True
    )
    assert und is None
    assert (intr.fx, intr.fy, intr.cx, intr.cy) == (520.0, 521.0, 320.0, 240.0)
    # all-zero P falls back to K for rectified images
    intr2, _ = intrinsics_from_camera_info(
        width=640, height=480, k=K, d=[], p=[0.0] * 12, distortion_model="", rectified=True
    )
    assert (intr2.fx, intr2.fy, intr2.cx, intr2.cy) == (525.0, 526.0, 319.5, 239.5)


def test_intrinsics_raw_uses_k_and_distortion() -> None:
    intr, und = intrinsics_from_camera_info(
        width=640, height=480, k=K, d=D5, p=P, distortion_model="plumb_bob", rectified=False
    )
    assert (intr.fx, intr.fy, intr.cx, intr.cy) == (525.0, 526.0, 319.5, 239.5)
    assert und is not None and (und.width, und.height) == (640, 480)
    _, none = intrinsics_from_camera_info(
        width=640, height=480, k=K, d=[0.0] * 5, p=P, distortion_model="plumb_bob", rectified=False
    )
    assert none is None
    _, rp = intrinsics_from_camera_info(
        width=640, height=480, k=K, d=[0.1, -0.05, 0, 0, 0.01, 0.02, 0.0, 0.0], p=P,
        distortion_model="rational_polynomial", rectified=False,
    )
    assert rp is not None


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"k": [0.0] * 9, "rectified": False}, "K is all zero"),
        ({"k": [0.0] * 9, "p": [0.0] * 12, "rectified": True}, "K and P are all zero"),
        ({"k": [-525.0, *K[1:]], "rectified": False}, "focal lengths must be positive"),
        ({"p": [*P[:5], 0.0, *P[6:]], "rectified": True}, "focal lengths must be positive"),
        ({"k": [np.nan, *K[1:]]}, "non-finite"),
        ({"p": [np.inf, *P[1:]]}, "non-finite"),
        ({"k": K[:8]}, "K must have 9"),
        ({"width": 0}, "size must be positive"),
        ({"d": [0.1, 0.2, 0.0]}, "plumb_bob"),
        ({"distortion_model": "equidistant"}, "unsupported distortion model"),
    ],
)
def test_camera_info_errors(kwargs: dict[str, Any], match: str) -> None:
    args: dict[str, Any] = {
        "width": 640, "height": 480, "k": K, "d": D5, "p": P, "distortion_model": "plumb_bob", "rectified": False,
    }
    args.update(kwargs)
    with pytest.raises(CameraInfoError, match=match):
        intrinsics_from_camera_info(**args)


def test_check_info_matches() -> None:
    intr, _ = intrinsics_from_camera_info(width=640, height=480, k=K, d=[], p=P, distortion_model="", rectified=True)
    check_info_matches(intr, width=640, height=480)
    with pytest.raises(CameraInfoError, match="320x240 does not match CameraInfo size 640x480"):
        check_info_matches(intr, width=320, height=240)


def test_undistortion_recovers_pinhole_image_without_blending() -> None:
    intr, und = intrinsics_from_camera_info(
        width=640, height=480, k=K, d=D_STRONG, p=P, distortion_model="plumb_bob", rectified=False
    )
    assert und is not None
    # ideal (pinhole) image whose value encodes its own pixel: 1 + u + 1000 v (exact in float32)
    vv, uu = np.mgrid[0:480, 0:640]
    truth = (1.0 + uu + 1000.0 * vv).astype(np.float32)
    # synthesise the raw (distorted) image: raw pixel -> ideal pixel via undistortPoints, nearest sample
    cam = np.array([[K[0], 0, K[2]], [0, K[4], K[5]], [0, 0, 1]])
    pix = np.stack([uu, vv], -1).reshape(-1, 1, 2).astype(np.float64)
    ideal = cv2.undistortPoints(pix, cam, np.array(D_STRONG), P=cam).reshape(480, 640, 2)
    iu, iv = np.rint(ideal[..., 0]).astype(int), np.rint(ideal[..., 1]).astype(int)
    inside = (iu >= 0) & (iu < 640) & (iv >= 0) & (iv < 480)
    raw = np.full((480, 640), np.nan, np.float32)
    raw[inside] = truth[iv[inside], iu[inside]]
    # the distortion is noticeable (pixels move by several px near the border) ...
    shift = np.hypot(ideal[..., 0] - uu, ideal[..., 1] - vv)
    assert shift.max() > 5.0
    out = und.apply(raw)
    ok = np.isfinite(out)
    assert ok.mean() > 0.85
    # ... and undistortion puts each ideal pixel back within one pixel of where it belongs
    code = out[ok].astype(np.int64) - 1
    got_u, got_v = code % 1000, code // 1000
    err = np.hypot(got_u - uu[ok], got_v - vv[ok])
    assert np.mean(err <= 1.5) > 0.99 and err.max() <= 3.0
    # nearest neighbour: every output value exists in the input (no blending across edges)
    assert np.all(np.isin(out[ok], raw[np.isfinite(raw)]))
    with pytest.raises(CameraInfoError, match="does not match"):
        und.apply(np.zeros((10, 10), np.float32))


# --------------------------------------------------------------------------- projector


def test_projector_matches_equation_2_and_caches_rays() -> None:
    rng = np.random.default_rng(3)
    depth = rng.uniform(0.5, 4.0, (6, 8)).astype(np.float32)
    depth[2, 3] = np.nan
    proj = DepthProjector(INTR)
    assert proj.rebuild_count == 1
    pts = proj.points(depth)
    assert pts.shape == (6, 8, 3) and pts.dtype == np.float32
    vv, uu = np.mgrid[0:6, 0:8]
    ref = INTR.backproject(uu, vv, depth)
    np.testing.assert_allclose(pts, ref, rtol=1e-5, equal_nan=True)
    assert np.all(np.isnan(pts[2, 3]))
    # caching: same intrinsics -> no rebuild; changes -> rebuild
    for _ in range(3):
        proj.points(depth)
        assert not proj.set_intrinsics(CameraIntrinsics(width=8, height=6, fx=5.0, fy=6.0, cx=3.5, cy=2.5))
    assert proj.rebuild_count == 1
    assert proj.set_intrinsics(CameraIntrinsics(width=8, height=6, fx=5.5, fy=6.0, cx=3.5, cy=2.5))
    assert proj.set_intrinsics(CameraIntrinsics(width=4, height=3, fx=2.5, fy=3.0, cx=1.5, cy=1.0))
    assert proj.rebuild_count == 3
    with pytest.raises(ValueError, match="does not match"):
        proj.points(depth)
    # reusable output buffer
    proj2 = DepthProjector(INTR)
    buf = np.empty((6, 8, 3), np.float32)
    assert proj2.points(depth, out=buf) is buf


def test_projector_stride() -> None:
    depth = np.arange(1, 49, dtype=np.float32).reshape(6, 8) / 10
    full = DepthProjector(INTR).points(depth)
    sub = DepthProjector(INTR, stride=2).points(depth)
    np.testing.assert_allclose(sub, full[::2, ::2], rtol=1e-6)
    with pytest.raises(ValueError):
        DepthProjector(INTR, stride=0)
    with pytest.raises(ValueError, match="no intrinsics"):
        DepthProjector().points(depth)


@pytest.mark.parametrize("stride", [1, 2, 3])
def test_compiled_back_projection_is_numpys_bit_for_bit(stride: int) -> None:
    """``points`` compiled (``_jit.back_project``) as numpy computes them: every coordinate, NaN and infinite depths
    included, into a fresh array, a reused buffer, and numpy's code where the buffer is not contiguous."""
    from walker_gait.core import _jit, kernels

    intr = CameraIntrinsics(width=97, height=61, fx=80.3, fy=79.1, cx=47.2, cy=31.9)
    depth = np.random.default_rng(5).uniform(0.3, 6.0, (61, 97)).astype(np.float32)
    depth[::7, ::5] = np.nan
    depth[3, 4] = np.inf
    got = {}
    for name, jit in (("numpy", None), ("compiled", _jit)):
        proj = DepthProjector(intr, stride=stride)
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(kernels, "compiled", lambda jit=jit: jit)
            buf = np.full((*proj.rays[0].shape, 3), 7.0, np.float32)
            got[name] = (proj.points(depth), proj.points(depth, out=buf), buf)
    for a, b in zip(got["numpy"], got["compiled"]):
        np.testing.assert_array_equal(b, a)
    assert got["compiled"][1] is got["compiled"][2]
    assert np.isnan(got["numpy"][0]).any() and np.isfinite(got["numpy"][0]).mean() > 0.9
    readonly = depth.copy()
    readonly.flags.writeable = False  # a message's bytes
    np.testing.assert_array_equal(DepthProjector(intr, stride=stride).points(readonly), got["numpy"][0])
    strided = np.empty((*got["numpy"][0].shape[:2], 4), np.float32)[..., :3]  # not contiguous: numpy's code
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(DepthProjector(intr, stride=stride).points(depth, out=strided), got["numpy"][0])


# --------------------------------------------------------------------------- real bag


def _real_bag() -> Path:
    path = (REAL_DATA / "xtion_person_32fc1.bag").resolve()
    if not path.is_file():
        pytest.fail(
            f"real test data not found at {path}: the repository expects the shared data "
            "checkout beside it (<repo>/../shared/data/real/xtion_person_32fc1.bag)"
        )
    return path


def read_real_bag() -> tuple[Any, Any]:
    """(depth Image, CameraInfo) messages of the real Xtion bag (ROS 1, read with rosbags)."""
    from rosbags.highlevel import AnyReader
    from rosbags.typesys import Stores, get_typestore

    depth_msg = info_msg = None
    with AnyReader([_real_bag()], default_typestore=get_typestore(Stores.ROS1_NOETIC)) as reader:
        for conn, _, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            if conn.topic == "/hero/head_rgbd_sensor/depth_registered/image":
                depth_msg = msg
            elif conn.topic == "/hero/head_rgbd_sensor/rgb/camera_info":
                info_msg = msg
    assert depth_msg is not None and info_msg is not None
    return depth_msg, info_msg


def _info_kwargs(info: Any) -> dict[str, Any]:
    # ROS 1 CameraInfo uses upper-case D/K/P; ROS 2 lower-case
    return {
        "width": info.width,
        "height": info.height,
        "k": getattr(info, "K", getattr(info, "k", None)),
        "d": getattr(info, "D", getattr(info, "d", None)),
        "p": getattr(info, "P", getattr(info, "p", None)),
        "distortion_model": info.distortion_model,
    }


def test_real_xtion_bag_decodes_to_sensible_geometry() -> None:
    depth_msg, info = read_real_bag()
    assert depth_msg.encoding == "32FC1"
    depth = decode_depth(
        depth_msg.data, encoding=depth_msg.encoding, width=depth_msg.width, height=depth_msg.height,
        step=depth_msg.step, is_bigendian=bool(depth_msg.is_bigendian),
    )
    assert depth.shape == (480, 640)
    valid = np.isfinite(depth)
    assert 0.2 < valid.mean() < 0.7  # shiny floor / far background give no reading
    z = depth[valid]
    assert 0.5 < np.percentile(z, 1) and np.percentile(z, 99) < 8.0
    assert 1.0 < np.median(z) < 4.0
    # the person standing at ~1.5-2.1 m in the image centre
    person = depth[150:400, 280:340]
    assert 1.5 < np.nanmedian(person) < 2.5

    for rectified in (True, False):
        intr, und = intrinsics_from_camera_info(**_info_kwargs(info), rectified=rectified)
        check_info_matches(intr, width=depth_msg.width, height=depth_msg.height)
        assert 400 < intr.fx < 700 and 400 < intr.fy < 700
        img = depth if und is None else und.apply(depth)
        assert (und is None) == rectified
        assert abs(np.isfinite(img).mean() - valid.mean()) < 0.05
        pts = DepthProjector(intr).points(img)
        good = np.isfinite(pts).all(axis=2)
        np.testing.assert_array_equal(good, np.isfinite(img))
        dist = np.linalg.norm(pts[good], axis=1)
        assert 0.5 < np.percentile(dist, 1) and np.percentile(dist, 99) < 8.5
        # the person is about 0.5 m wide and upright (extent along image y much larger than x)
        person_pts = pts[100:450, 250:380][np.abs(img[100:450, 250:380] - 1.95) < 0.25]
        assert person_pts.shape[0] > 5000
        ext = np.percentile(person_pts, 95, axis=0) - np.percentile(person_pts, 5, axis=0)
        assert 0.2 < ext[0] < 0.9 and 0.8 < ext[1] < 2.2
        # a dominant plane facing the camera (wall / furniture front) is found by the generic RANSAC
        cfg = FloorConfig(up_hint=(0.0, 0.0, -1.0), max_tilt_deg=89.0, max_camera_height=10.0,
                          max_fit_range=8.0, max_below_fraction=1.0)
        plane = fit_floor_ransac(pts[::4, ::4].reshape(-1, 3), rng=np.random.default_rng(0), config=cfg)
        assert plane.valid and plane.inlier_ratio > 0.1 and plane.rms < 0.05
