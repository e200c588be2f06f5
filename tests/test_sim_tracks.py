"""Tracks: every shared track file loads, the centreline lies between the cones, the generator
follows the Formula Student rules, bad files give clear errors."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

from common.errors import TrackError
from common.messages import ConeColour, ConeSize
from common.polyline import nearest_on_polyline
from simulator.track_generator import check_fs_rules, default_track, generate_track
from simulator.tracks import find_shared_track, load_track
from support.shared_data import shared_path

DATA = shared_path("tracks")
TRACK_FILES = sorted(DATA.glob("*/*.csv")) + sorted(DATA.glob("*/*.yaml"))

pytestmark = pytest.mark.shared_data("tracks")


def _expected_counts(path: Path) -> dict[int, int]:
    """Cone counts per colour, read straight from the file; a cone written twice at the very
    same place (FSG.yaml's first cone repeated at the end of its row) counts once."""
    seen: set[tuple[int, float, float]] = set()
    if path.suffix == ".csv":
        names = {"blue": ConeColour.BLUE, "yellow": ConeColour.YELLOW,
                 "orange": ConeColour.ORANGE, "big_orange": ConeColour.BIG_ORANGE}
        for line in path.read_text().splitlines():
            fields = line.split(",")
            if fields[0].strip() in names:
                seen.add((names[fields[0].strip()], round(float(fields[1]), 3),
                          round(float(fields[2]), 3)))
    else:
        import yaml

        data = yaml.safe_load(path.read_text())
        for key, colour in (("cones_left", ConeColour.BLUE), ("cones_right", ConeColour.YELLOW),
                            ("cones_orange", ConeColour.ORANGE),
                            ("cones_orange_big", ConeColour.BIG_ORANGE)):
            for x, y, *_ in data.get(key) or []:
                seen.add((colour, round(float(x), 3), round(float(y), 3)))
    counts: dict[int, int] = {}
    for colour, _, _ in seen:
        counts[colour] = counts.get(colour, 0) + 1
    return counts


def test_track_files_present() -> None:
    assert len(TRACK_FILES) >= 8


@pytest.mark.parametrize("path", TRACK_FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_track_file_loads_with_its_cone_counts(path: Path) -> None:
    track = load_track(str(path))
    expected = _expected_counts(path)
    got = {c: int(np.sum(track.colours == c)) for c in expected}
    assert got == expected
    assert len(track.cones_xy_m) == sum(expected.values())
    big = track.colours == ConeColour.BIG_ORANGE
    assert np.all(track.sizes[big] == ConeSize.LARGE)
    assert np.all(track.sizes[~big] == ConeSize.SMALL)
    assert track.lap_length_m > 50.0
    assert np.all(np.isfinite(track.centreline_xy_m))
    # the car starts at the origin facing +x, on the track near the centreline
    s, lateral, _ = track.locate(0.0, 0.0)
    assert abs(lateral) < 1.0
    x, y, heading = track.point_at(s + 1.0)
    assert abs(math.atan2(math.sin(heading), math.cos(heading))) < 0.2


@pytest.mark.parametrize("path", [p for p in TRACK_FILES if "skidpad" not in p.name],
                         ids=lambda p: f"{p.parent.name}/{p.name}")
def test_centreline_lies_between_left_and_right_cones(path: Path) -> None:
    track = load_track(str(path))
    c = track.centreline_xy_m
    # each blue cone is left of the centreline, each yellow cone right of it
    for colour, sign in ((ConeColour.BLUE, 1.0), (ConeColour.YELLOW, -1.0)):
        cones = track.cones_xy_m[track.colours == colour]
        lateral = np.array([track.locate(float(x), float(y))[1] for x, y in cones])
        assert np.all(sign * lateral > 0.5), (colour, lateral.min(), lateral.max())
    # and every centreline sample is at least 0.5 m from both boundaries
    if track.is_loop:
        dl = nearest_on_polyline(c, track.left_xy_m, True)[0]
        dr = nearest_on_polyline(c, track.right_xy_m, True)[0]
        assert dl.min() > 0.5 and dr.min() > 0.5
        assert np.abs(dl - dr).max() < 1.5  # roughly in the middle


def test_skidpad_centreline_is_on_the_circles() -> None:
    for path in [p for p in TRACK_FILES if "skidpad" in p.name]:
        track = load_track(str(path))
        assert track.kind == "skidpad" and not track.is_loop
        # every knocked-cone-free path: centreline samples keep 1 m from every cone
        c = track.centreline_xy_m
        d = np.hypot(c[:, None, 0] - track.cones_xy_m[None, :, 0],
                     c[:, None, 1] - track.cones_xy_m[None, :, 1])
        assert d.min() > 1.0, path.name
        # two right laps then two left laps: about 4 circumferences of ~9.1 m radius
        assert 4 * 2 * math.pi * 8.5 < track.lap_length_m < 4 * 2 * math.pi * 9.5 + 60


def test_acceleration_is_a_straight_not_a_loop() -> None:
    for path in [p for p in TRACK_FILES if "accel" in p.name]:
        track = load_track(str(path))
        assert track.kind == "acceleration" and not track.is_loop
        assert np.all(np.isfinite(track.finish_line_xy_m))
        # start and finish lines 75 m apart
        gap = np.hypot(*(track.finish_line_xy_m.mean(axis=0) - track.start_line_xy_m.mean(axis=0)))
        assert abs(gap - 75.0) < 1.0


def test_fsg_start_line_is_the_big_orange_gate() -> None:
    track = load_track(str(DATA / "amz_fssim" / "FSG.yaml"))
    mid = track.start_line_xy_m.mean(axis=0)
    # FSSIM gives the front wing at x=0; the gate is at 6 m, the rear axle 2.25 m behind
    assert mid[0] == pytest.approx(8.25, abs=0.05)
    assert abs(mid[1]) < 0.1
    assert 300.0 < track.lap_length_m < 320.0


def test_default_track() -> None:
    track = load_track("default")
    assert track.name == "default"
    assert track.is_loop
    assert 250.0 <= track.lap_length_m <= 350.0
    assert 3.5 <= track.width_m <= 4.0
    assert check_fs_rules(track) == []
    assert int(np.sum(track.colours == ConeColour.BIG_ORANGE)) == 4
    assert track is default_track()


def test_generator_makes_rule_abiding_tracks_for_50_seeds() -> None:
    lengths = []
    for seed in range(50):
        track = generate_track(seed)
        assert check_fs_rules(track) == [], seed
        assert track.is_loop and track.name == f"gen:{seed}"
        lengths.append(track.lap_length_m)
    assert len(set(np.round(lengths, 3))) == 50  # all different


def test_generator_is_deterministic() -> None:
    a = generate_track.__wrapped__(7)
    b = generate_track.__wrapped__(7)
    np.testing.assert_array_equal(a.cones_xy_m, b.cones_xy_m)
    assert load_track("gen:7").lap_length_m == pytest.approx(a.lap_length_m)


def test_rule_checker_flags_broken_rules() -> None:
    track = generate_track.__wrapped__(3)
    # drop every other left cone: gaps over 5 m
    keep = np.ones(len(track.left_xy_m), bool)
    keep[::2] = False
    track = dataclasses.replace(track, left_xy_m=track.left_xy_m[keep])
    problems = check_fs_rules(track)
    assert any("left cones" in p for p in problems)
    fsg = load_track(str(DATA / "amz_fssim" / "FSG.yaml"))
    assert not any("lap" in p or "hairpin" in p or "straight" in p for p in check_fs_rules(fsg))


def test_cones_touched_and_off_track() -> None:
    track = load_track("default")
    i = int(np.nonzero(track.colours == ConeColour.BLUE)[0][5])
    x, y = track.cones_xy_m[i]
    square = np.array([[x - 0.5, y - 0.5], [x + 0.5, y - 0.5], [x + 0.5, y + 0.5],
                       [x - 0.5, y + 0.5]])
    assert i in track.cones_touched(square)
    # just clear of the cone's base (radius 0.114 m)
    clear = square + np.array([0.5 + 0.114 + 0.01, 0.0])
    assert i not in track.cones_touched(clear)
    # a car-sized box on the centreline is on the track; 10 m to the side it is off
    car = np.array([[-0.65, -0.7], [2.25, -0.7], [2.25, 0.7], [-0.65, 0.7]])
    assert not track.is_off_track(car)
    assert track.cones_touched(car) == []
    s, lat, seg = track.locate(0.0, 0.0)
    assert not track.is_off_track(car + np.array([0.0, 1.0]))
    assert track.is_off_track(car + np.array([0.0, -10.0]))


def test_progress_increases_along_the_lap() -> None:
    track = load_track("default")
    s = [track.progress_m(*track.point_at(q)[:2]) for q in np.arange(0.0, 280.0, 7.0)]
    assert np.all(np.diff(s) > 0)
    assert s[0] == pytest.approx(0.0, abs=1e-6)


def test_missing_start_pose_and_repeated_headers(tmp_path: Path) -> None:
    src = (DATA / "eufs" / "small_track.csv").read_text().splitlines()
    header, rows = src[0], [r for r in src[1:] if not r.startswith("car_start")]
    rng = np.random.default_rng(0)
    rows = [rows[i] for i in rng.permutation(len(rows))]
    text = "\n".join([header, *rows[:30], header, "", *rows[30:]]) + "\n"
    path = tmp_path / "shuffled.csv"
    path.write_text(text)
    track = load_track(str(path))
    ref = load_track(str(DATA / "eufs" / "small_track.csv"))
    assert len(track.cones_xy_m) == len(ref.cones_xy_m)
    assert track.lap_length_m == pytest.approx(ref.lap_length_m, rel=0.03)
    # the car is put on the centreline before the start line, facing along the track
    assert 0.0 < track.start_line_s_m < 10.0


def test_a_cone_written_twice_is_kept_once(tmp_path: Path,
                                            caplog: pytest.LogCaptureFixture) -> None:
    """Layouts built from lines and arcs repeat the cone where two pieces meet (EPFL's track
    database: 18 of 75 in its autocross layout; FSG.yaml repeats its first cone): one cone of a
    colour within 0.1 m of another is the same cone. A cone of another colour there is kept."""
    src = (DATA / "eufs" / "small_track.csv").read_text().splitlines()
    blue = next(r for r in src if r.startswith("blue,"))
    _, x, y, *rest = blue.split(",")
    near = ",".join(["blue", str(float(x) + 0.05), y, *rest])
    other = ",".join(["yellow", x, y, *rest])
    path = tmp_path / "twice.csv"
    path.write_text("\n".join([*src, blue, near, other]) + "\n")
    ref = load_track(str(DATA / "eufs" / "small_track.csv"))
    with caplog.at_level("WARNING"):
        track = load_track(str(path))
    assert len(track.cones_xy_m) == len(ref.cones_xy_m) + 1
    assert "2 cones written twice" in caplog.text


def test_an_open_layout_is_refused_as_not_a_closed_loop(tmp_path: Path) -> None:
    """A U of two lanes and one bend (EPFL's VSV layouts): the rows end 12 and 18 m from where
    they start; autocross and trackdrive need a closed track, and the error says so instead of
    the width the missing side would give."""
    rows = []
    for x_m, tag in ((-1.5, "blue"), (1.5, "yellow"), (-13.5, "blue"), (-16.5, "yellow")):
        rows += [f"{tag},{x_m},{y_m}" for y_m in np.arange(0.0, 30.1, 3.75)]
    for a in np.linspace(0.0, math.pi, 7)[1:-1]:
        rows += [f"blue,{-7.5 + 6.0 * math.cos(a)},{30.0 + 6.0 * math.sin(a)}",
                 f"yellow,{-7.5 + 9.0 * math.cos(a)},{30.0 + 9.0 * math.sin(a)}"]
    path = tmp_path / "u.csv"
    path.write_text("tag,x,y\n" + "\n".join(rows) + "\n")
    with pytest.raises(TrackError, match="not a closed loop: the (left|right) cones' row ends"):
        load_track(str(path))


def test_columns_are_read_by_the_names_in_the_header(tmp_path: Path) -> None:
    """EPFL's track database writes ``cone_type,X,Y,Z,std_X,...``; the columns are found by
    their names (here in another order), and a header without x and y is refused."""
    src = (DATA / "eufs" / "small_track.csv").read_text().splitlines()
    rows = [r.split(",") for r in src[1:] if not r.startswith("car_start")]
    path = tmp_path / "epfl.csv"
    path.write_text("cone_type,Z,Y,X,std_X\n"
                    + "".join(f"{r[0]},0.0,{r[2]},{r[1]},0.0\n" for r in rows))
    ref = load_track(str(DATA / "eufs" / "small_track.csv"))
    track = load_track(str(path))
    assert len(track.cones_xy_m) == len(ref.cones_xy_m)
    assert track.lap_length_m == pytest.approx(ref.lap_length_m, rel=0.03)
    path.write_text("cone_type,X,Z\nblue,1.0,2.0\n")
    with pytest.raises(TrackError, match="without x and y"):
        load_track(str(path))


@pytest.mark.parametrize("content, message", [
    ("tag,x,y\nblue,1,oops\n", "not numbers"),
    ("tag,x,y\npurple,1,2\n", "unknown tag"),
    ("tag,x,y\n", "no cones"),
    ("tag,x,y\nblue,0,2\nblue,5,2\nyellow,0,-2\n", "at least"),
])
def test_bad_csv_files_give_clear_errors(tmp_path: Path, content: str, message: str) -> None:
    path = tmp_path / "bad.csv"
    path.write_text(content)
    with pytest.raises(TrackError, match=message):
        load_track(str(path))


def test_bad_names_and_yaml(tmp_path: Path) -> None:
    with pytest.raises(TrackError, match="no such file"):
        load_track("nope.csv")
    with pytest.raises(TrackError, match="gen:SEED"):
        load_track("gen:abc")
    path = tmp_path / "bad.yaml"
    path.write_text("just: text\n")
    with pytest.raises(TrackError, match="cones_left"):
        load_track(str(path))
    path.write_text("cones_left: [[1, 2, 3], 4]\n")
    with pytest.raises(TrackError, match="cones_left"):
        load_track(str(path))


def test_a_track_narrower_than_the_car_is_refused_with_its_widths() -> None:
    """A layout at the wrong scale (0.8 m between cone centres) cannot be driven by anyone:
    refused, the message giving its width (a little under 0.8 m: the chords between cones on the
    bend) and what the car needs; a 3 m track passes."""
    import numpy as np

    from common.errors import TrackError
    from simulator.track_generator import track_from_centreline

    a = np.linspace(0.0, 2 * np.pi, 300, endpoint=False)
    centre = np.c_[20.0 * np.cos(a), 20.0 * np.sin(a)]
    track_from_centreline("wide", centre, 3.0, 0).check_drivable(1.4)
    narrow = track_from_centreline("narrow", centre, 0.8, 0)
    with pytest.raises(TrackError, match=r"0\.[67]\d m wide .* needs 1\.70 m"):
        narrow.check_drivable(1.4)


def test_a_bare_file_name_is_found_among_the_shared_tracks() -> None:
    by_name = load_track("FSG.yaml")
    by_path = load_track(str(DATA / "amz_fssim" / "FSG.yaml"))
    assert by_name.lap_length_m == pytest.approx(by_path.lap_length_m)
    assert find_shared_track("FSG.yaml") == DATA / "amz_fssim" / "FSG.yaml"
    assert find_shared_track("FSG") == DATA / "amz_fssim" / "FSG.yaml"
    assert load_track("FSG").lap_length_m == pytest.approx(by_path.lap_length_m)
    with pytest.raises(TrackError, match="no such file"):
        load_track("no_such_track.csv")
    with pytest.raises(TrackError, match="no such file"):
        load_track("no_such_track")


def test_a_bare_name_of_several_shared_files_asks_for_the_path(tmp_path: Path) -> None:
    for folder in ("a", "b"):
        (tmp_path / folder).mkdir()
        (tmp_path / folder / "oval.csv").write_text("tag,x,y\n")
    with pytest.raises(TrackError, match="several files of that name"):
        find_shared_track("oval.csv", tmp_path)
    assert find_shared_track("other.csv", tmp_path) is None
    # without its suffix a name may match files of either format: the path decides
    (tmp_path / "a" / "loop.csv").write_text("tag,x,y\n")
    (tmp_path / "b" / "loop.yaml").write_text("cones_left: []\n")
    with pytest.raises(TrackError, match=r"several files of that name.*a/loop\.csv.*b/loop\.yaml"):
        find_shared_track("loop", tmp_path)
    assert find_shared_track("loop.csv", tmp_path) == tmp_path / "a" / "loop.csv"
