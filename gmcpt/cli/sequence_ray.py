"""``gmcpt batch SCENE --frames A:B --history N --ray ADDRESS``: a sequence's frames in chunks of consecutive
frames, one Ray task a chunk.

A task first renders, without writing them, the ``N + 2`` frames before its chunk (the warm-up,
:func:`warm_up_frames`): their samples are the history of the chunk's first frame. Then it renders and writes the
chunk's frames, with the files and records of the one-process path (:mod:`gmcpt.cli.sequence_batch`). A frame's
samples are seeded by its index, but where they fall follows the history, so two tasks' renders of a frame draw
different samples: at a chunk's first frame the noise would change all at once, where inside a chunk each frame
shares most of its samples and a share of its image (:data:`gmcpt.temporal.sequence.SHOWN_CARRY`) with the frame
before. So the last frames of a chunk (:func:`blend_frames`) are cross-faded into the next chunk's renders of them,
its warm-up's last frames, rising towards the next chunk: the change is spread over those frames, and the driver
writes them when both halves are in.

Resuming is per frame, through the frames' records (:func:`gmcpt.cli.batch_records.finished_record`, made with the same
history): the state folder ``.sequence-state`` belongs to the one-process path. A task renders from its warm-up
before the first frame it still owes (a stopped batch, or a task Ray runs again after its worker died) to the last.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..errors import GmcptError

#: A default chunk holds at least this many times the history: warm-up at most a third of a task's renders.
CHUNK_HISTORIES = 2


@dataclass(frozen=True)
class Chunk:
    """One task's frames (:func:`chunks`), in order: ``warm`` (rendered first, unwritten), then ``frames``.
    ``tail``: the chunk's last frames, cross-faded with the next chunk's renders of them; ``lead``: the warm-up's
    last frames, the next chunk's half of the chunk before's tail."""

    warm: list
    frames: list
    tail: list
    lead: list


def check(args) -> None:
    """One line for a ``--chunk`` a sequence cannot use."""
    chunk = getattr(args, "chunk", None)
    if chunk is None:
        return
    if args.ray is None:
        raise GmcptError("--chunk splits a sequence into Ray tasks: give --ray too")
    if chunk < 1:
        raise GmcptError(f"--chunk must be >= 1, got {chunk}")


def warm_up_frames(history: int) -> int:
    """Frames a task renders before its first owed one: the history's, whose samples its first frame reuses, and two
    more before them: the history's first frames have history of their own, so they place and weigh their samples as
    one process's do (without them the Cornell box's chunks in tests/test_sequence_ray.py read 0.5 dB under one
    process)."""
    return history + 2 if history else 0


def blend_frames(history: int) -> int:
    """Frames cross-faded at a chunk's end: half the warm-up, so the next chunk's renders blended in have at least
    half the history behind them (its first ones, with little, are noisier)."""
    return history // 2


def chunks(frames: Sequence, size: int, history: int, blend: int = 0) -> list[Chunk]:
    """``frames`` (in order) as consecutive chunks of ``size`` (the last may be shorter), each after the up to
    ``history`` frames before it, which make its first frame's history; the last ``blend`` frames of each (at most
    ``size`` and ``history``) cross-faded with the next."""
    blend = min(blend, size, history)
    starts = range(0, len(frames), size)
    return [Chunk(list(frames[max(0, start - history):start]), list(frames[start:start + size]),
                  list(frames[start + size - blend:start + size]) if start + size < len(frames) else [],
                  list(frames[start - blend:start]) if start else [])
            for start in starts]


def default_size(frames: int, workers: int, history: int) -> int:
    """Frames a chunk: one chunk a worker, but at least :data:`CHUNK_HISTORIES` x ``history``, as the warm-up
    is work a one-process run does not do."""
    return max(-(-frames // max(workers, 1)), CHUNK_HISTORIES * history, 1)


def workers(resources: dict, cpus: float, gpus: float) -> int:
    """Tasks of ``cpus`` CPUs and ``gpus`` GPUs the cluster's ``resources`` run at once (at least 1)."""
    counts = [resources.get("CPU", 0) // cpus] + ([resources.get("GPU", 0) // gpus] if gpus else [])
    return max(1, int(min(counts)))


def span(needed: list[bool], history: int) -> range:
    """The positions a task renders of its frames in order (``needed``: whether each is owed, written or handed
    over): from ``history`` before the first owed to the last; none when nothing is owed."""
    owed = [position for position, need in enumerate(needed) if need]
    return range(max(0, owed[0] - history), owed[-1] + 1) if owed else range(0)


def weight(tail: list, job: dict) -> float:
    """The next chunk's share of ``job``, a frame of a chunk's ``tail``: rising by equal steps to the next chunk."""
    return (tail.index(job) + 1) / (len(tail) + 1)


def finished(job: dict, history: int) -> bool:
    """True if ``job``'s frame is written, for the same request, as a sequence frame of this ``history``."""
    from .batch_records import finished_record

    record = finished_record(job)
    parameters = record.get("parameters", {}) if record is not None else {}
    return parameters.get("sequence") is True and parameters.get("history") == history


def _use_threads(threads: int) -> None:
    """Torch's and Dr.Jit's threads in a task: the CPUs Ray gave it, not the node's."""
    import drjit as dr
    import torch

    torch.set_num_threads(threads)
    dr.set_thread_count(threads)


def render_chunk(task: dict) -> dict:
    """A Ray task: render ``task["chunk"]`` from its warm-up, write the frames it owes, and hand back the frames
    ``task["handed"]`` names (its tail's and its lead's, for the driver to cross-fade). Returns ``{"rows": the
    summary rows of the frames written or found written (by an earlier run of this task), "handed": {name:
    (role: "tail" or "lead", (image, record, seconds))}}``."""
    from .batch_records import crash_once
    from .command import start_mitsuba
    from ..temporal.sequence import SequenceRenderer
    from .sequence_batch import frame_row, frame_scene, render_frame, scene_frames, sequence_settings, write_frame

    start_mitsuba()
    args, chunk, handed = task["args"], task["chunk"], set(task["handed"])
    _use_threads(args.threads)
    owned = [job for job in chunk.frames if job not in chunk.tail and job["name"] in task["owed"]]
    written = {job["name"] for job in owned if finished(job, args.history)}
    result = {"rows": [frame_row(job, "found") for job in owned if job["name"] in written], "handed": {}}
    ordered = chunk.warm + chunk.frames
    owes = [job["name"] in handed or (job in owned and job["name"] not in written) for job in ordered]
    renderer, frames = None, scene_frames(args, ordered[0])
    for position in span(owes, warm_up_frames(args.history)):
        started, job = time.perf_counter(), ordered[position]
        scene, parameters, scene_seconds = frame_scene(frames, job)
        renderer = renderer or SequenceRenderer(sequence_settings(args, scene))
        image, record = render_frame(args, renderer, job, scene, parameters, scene_seconds)
        if job["name"] in handed:
            role = "tail" if job in chunk.tail else "lead"
            result["handed"][job["name"]] = (role, (image, record, time.perf_counter() - started))
        elif owes[position]:
            write_frame(job, image, record)
            result["rows"].append(frame_row(job, "rendered", time.perf_counter() - started, record["timings"]))
            crash_once()  # test hook: a worker lost with part of its chunk written
    return result


def _tasks(args, jobs: list[dict], size: int, done: set) -> list[dict]:
    """The tasks of the chunks with frames not in ``done`` (names): each owes those of its frames, and hands over
    its tail and lead where they are not."""
    tasks = []
    for chunk in chunks(jobs, size, warm_up_frames(args.history), blend_frames(args.history)):
        owed = [job["name"] for job in chunk.frames if job["name"] not in done]
        handed = [job["name"] for job in chunk.tail + chunk.lead if job["name"] not in done]
        if owed or handed:
            tasks.append({"args": args, "chunk": chunk, "owed": owed, "handed": handed})
    return tasks


def _write_blended(job: dict, tail: list, halves: dict) -> dict:
    """Write ``job``, a frame of a chunk's ``tail``, cross-faded from the chunk's render (``halves["tail"]``: image,
    record, seconds) into the next chunk's (``halves["lead"]``); returns its summary row."""
    from .sequence_batch import frame_row, write_frame

    share = weight(tail, job)
    (image, record, seconds), next_chunk = halves["tail"], halves["lead"]
    blended = ((1 - share) * image + share * next_chunk[0]).astype(np.float32)
    write_frame(job, blended, {**record, "next_chunk_share": share})
    return frame_row(job, "rendered", seconds + next_chunk[2], record["timings"])


def run(args, jobs: list[dict], say, bar) -> dict:
    """Render ``jobs`` (one scene's frames, in order) as a sequence in chunks on the Ray cluster ``args.ray``;
    returns the summary rows by name. Frames already written for this request are skipped."""
    from ..runtime.cluster import connected, default_gpus, run_tasks
    from .sequence_batch import frame_row

    rows = {job["name"]: frame_row(job, "skipped") for job in jobs if finished(job, args.history)}
    with connected(args.ray, quiet=args.quiet) as resources:
        gpus = default_gpus(resources) if args.gpus is None else args.gpus
        size = args.chunk or default_size(len(jobs), workers(resources, args.threads, gpus), args.history)
        tasks = _tasks(args, jobs, size, set(rows))
        say(f"{len(rows)} frames already complete; {len(tasks)} chunks of up to {size} frames on Ray ({args.ray}), "
            f"each after up to {warm_up_frames(args.history)} frames of warm-up")
        tails = {job["name"]: (job, task["chunk"].tail) for task in tasks for job in task["chunk"].tail}
        halves: dict[str, dict] = {name: {} for name in tails}
        for result in run_tasks(render_chunk, tasks, cpus=args.threads, gpus=gpus, max_retries=args.retries):
            found = list(result["rows"])
            for name, (role, rendered) in result["handed"].items():
                halves[name][role] = rendered
                if len(halves[name]) == 2:
                    found.append(_write_blended(*tails[name], halves.pop(name)))
            for row in found:
                if row["name"] not in rows:
                    rows[row["name"]] = row
                    bar.update(note=f"{row['name']} {row['seconds']:.1f}s")
    return rows
