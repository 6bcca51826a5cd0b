"""examples/record_video.py: Gymnasium's RecordVideo writes an mp4 of an episode of each id."""

from conftest import require

IDS = ["ios_uav_env/IOSUAV-v0", "ios_uav_env/IOSUAV-Random-v0"]


def test_record_video(run_example, tmp_path):
    require("moviepy", "matplotlib")
    out = run_example("record_video.py", "--env", *IDS, "--out", str(tmp_path), "--frames", "10")
    for env_id in IDS:
        videos = list(tmp_path.glob(f"{env_id.replace('/', '-')}*.mp4"))
        assert len(videos) == 1 and videos[0].stat().st_size > 1000, out
        assert videos[0].read_bytes()[4:8] == b"ftyp"  # an MP4 container
