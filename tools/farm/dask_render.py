"""Renders a shot with rain-composite on a Dask cluster: split into chunks, one task per chunk,
joined losslessly at the end.

    python dask_render.py IN.mp4 OUT.mkv --chunk-frames 250 [--scheduler tcp://host:8786]
        [--workers 4] [--binary rain-composite] [--work-dir DIR] -- [rain-composite options]

Without --scheduler it starts a LocalCluster of --workers processes on this machine. With one,
the workers must see the input, the binary and --work-dir at the same paths (shared storage),
as on any render farm. Every chunk is written as FFV1 in Matroska, so the joined file is the
single render packet for packet; transcode it afterwards for delivery.

How it maps to farm managers: a chunk is an OpenCue frame-range chunk (a layer's "chunk size")
or a Flamenco task; the join is a second layer (OpenCue) or a final task depending on all the
others (Flamenco); Dask's `retries` is their per-task retry count. Dask is used here because it
installs from PyPI and runs a real scheduler and workers on one machine for tests.
"""

import argparse
import contextlib
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile

from distributed import Client, LocalCluster

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import join  # noqa: E402  (next to this file)


def frame_count(path):
    """Frames of the first video stream, by counting its packets (no decoding)."""
    out = subprocess.run(
        ["ffprobe", "-v", "error", "-select_streams", "v:0", "-count_packets",
         "-show_entries", "stream=nb_read_packets", "-print_format", "json", path],
        check=True, capture_output=True, text=True).stdout
    return int(json.loads(out)["streams"][0]["nb_read_packets"])


def chunk_ranges(frames, chunk_frames):
    """`--frames` arguments covering [0, frames); the last runs to the end of the shot, so a
    frame the count missed is still rendered."""
    starts = list(range(0, frames, chunk_frames))
    return ["%d..%d" % (a, a + chunk_frames) for a in starts[:-1]] + ["%d.." % starts[-1]]


def render_chunk(binary, source, frames, output, options):
    """One task: `rain-composite SOURCE --frames FRAMES -o OUTPUT` as FFV1; returns OUTPUT."""
    cmd = [binary, source, "-o", output, "-y", "--codec", "ffv1", "--progress", "none",
           "--frames", frames] + options
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError("chunk %s failed: %s" % (frames, done.stderr.strip()))
    return output


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("input")
    ap.add_argument("output", help="the joined render (.mkv)")
    ap.add_argument("--chunk-frames", type=int, default=250)
    ap.add_argument("--scheduler", help="address of a running Dask scheduler")
    ap.add_argument("--workers", type=int, default=2, help="local workers without --scheduler")
    ap.add_argument("--binary", default="rain-composite")
    ap.add_argument("--work-dir", help="where chunks are written (shared on a cluster)")
    ap.add_argument("--retries", type=int, default=2)
    argv = sys.argv[1:]
    # After `--`: options for rain-composite (--config, --set, --rain, ...).
    split = argv.index("--") if "--" in argv else len(argv)
    args, options = ap.parse_args(argv[:split]), argv[split + 1:]
    if not args.output.endswith(".mkv"):
        sys.exit("error: the joined output is Matroska FFV1: give a name ending in .mkv")
    if args.chunk_frames < 1:
        sys.exit("error: --chunk-frames must be at least 1")
    source = os.path.abspath(args.input)
    ranges = chunk_ranges(frame_count(source), args.chunk_frames)

    work = tempfile.mkdtemp(prefix="rain-chunks-", dir=args.work_dir)
    outputs = [os.path.join(work, "chunk_%05d.mkv" % i) for i in range(len(ranges))]
    with contextlib.ExitStack() as stack:
        if args.scheduler:
            client = stack.enter_context(Client(args.scheduler))
        else:
            # Task failures reach us through gather(); the cluster's own log would add only
            # the heartbeat errors its workers print when it shuts down under load.
            cluster = stack.enter_context(LocalCluster(
                n_workers=args.workers, threads_per_worker=1, processes=True,
                dashboard_address=None, silence_logs=logging.CRITICAL))
            client = stack.enter_context(Client(cluster))
        n = len(ranges)
        futures = client.map(render_chunk, [args.binary] * n, [source] * n, ranges, outputs,
                             [options] * n, retries=args.retries, pure=False)
        try:
            done = client.gather(futures)
            join.join(done, args.output, os.path.join(work, "chunks.ffconcat"))
        except (RuntimeError, subprocess.CalledProcessError) as e:
            sys.exit("error: %s" % e)
        finally:
            shutil.rmtree(work, ignore_errors=True)
    print("%s: %d chunks of %d frames joined" % (args.output, len(ranges), args.chunk_frames))


if __name__ == "__main__":
    main()
