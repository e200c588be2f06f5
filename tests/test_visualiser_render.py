"""The renderer draws what it is given where it belongs: cone colours at the cones' pixels."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from common.messages import ActuatorCommand, ConeColour, ConeMap, MapState, PoseEstimate
from orchestrator.config import AppConfig
from visualiser.frame_data import frame_from_messages
from visualiser.renderer import CAR_RGB, CONE_RGB, ellipse_points
from visualiser.transform import WorldToPixel
from visualiser.visualiser import FrameRenderer, Visualiser, frame_file_name


def known_map() -> MapState:
    xy = np.array([[10.0, 4.0], [20.0, -4.0], [30.0, 4.0], [-10.0, -4.0], [0.0, 12.0]])
    colours = [ConeColour.BLUE, ConeColour.YELLOW, ConeColour.ORANGE, ConeColour.BIG_ORANGE,
               ConeColour.UNKNOWN]
    cones = ConeMap(xy, np.tile(np.eye(2) * 1e-4, (5, 1, 1)), colours, [1, 1, 1, 2, 1],
                    np.ones(5), np.arange(5))
    pose = PoseEstimate(3.0, 0.0, -5.0, 0.0, 5.0, covariance=np.diag([0.01, 0.01, 0.001]))
    return MapState(3.0, pose, cones, loop_closed=True, backend="test")


def test_transform_round_trip_and_orientation() -> None:
    view = WorldToPixel(800, 600, 0.0, 0.0, 10.0)
    assert view.to_px([0.0, 0.0]) == pytest.approx([400.0, 300.0])
    assert view.to_px([1.0, 1.0]) == pytest.approx([410.0, 290.0])  # y up the image
    pts = np.array([[3.5, -2.0], [100.0, 7.0]])
    assert view.to_world(view.to_px(pts)) == pytest.approx(pts)
    fit = WorldToPixel.fit(800, 600, pts)
    px = fit.to_px(pts)
    assert np.all((px >= 0) & (px <= [800, 600]))


def test_ellipse_points_lie_on_two_sigma() -> None:
    cov = np.array([[[4.0, 0.0], [0.0, 1.0]]])
    pts = ellipse_points(np.zeros((1, 2)), cov, n_sigma=2.0, steps=32)[0]
    # Points satisfy x^2/16 + y^2/4 = 1 (2 sigma of sd 2 and 1).
    assert pts[:, 0] ** 2 / 16 + pts[:, 1] ** 2 / 4 == pytest.approx(np.ones(32))


def test_cone_colours_found_at_cone_pixels_and_car_where_it_is() -> None:
    renderer = FrameRenderer(640, 480)
    map_state = known_map()
    frame = frame_from_messages(map_state, None, ActuatorCommand(3.0, 0.2, 0.0, 0.1))
    surface = renderer.render(frame)
    view = renderer.view_for(frame)
    for (x, y), colour in zip(map_state.cones.xy_m, map_state.cones.colour, strict=True):
        u, v = np.round(view.to_px([x, y])).astype(int)
        assert tuple(surface.get_at((int(u), int(v))))[:3] == CONE_RGB[int(colour)]
    # The car's outline passes through the midpoint of its rear edge.
    pose = map_state.pose
    rear_mid = [pose.x_m - 0.65 * math.cos(pose.yaw_rad), pose.y_m - 0.65 * math.sin(pose.yaw_rad)]
    u, v = np.round(view.to_px(rear_mid)).astype(int)
    window = [tuple(surface.get_at((int(u + du), int(v + dv))))[:3]
              for du in (-1, 0, 1) for dv in (-1, 0, 1)]
    assert CAR_RGB in window


def test_visualiser_process_writes_frames_named_by_time(tmp_path: Path) -> None:
    config = AppConfig()
    config.visualiser.width_px, config.visualiser.height_px = 320, 240
    with Visualiser(config.visualiser, tmp_path) as vis:
        for _ in range(3):
            assert vis.submit(known_map(), None, None) or vis.dropped
    files = sorted(p.name for p in tmp_path.glob("frame_*.png"))
    assert frame_file_name(3.0) in files
    from PIL import Image

    assert Image.open(tmp_path / files[0]).size == (320, 240)
