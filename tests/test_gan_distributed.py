"""Data-parallel training under torchrun: two CPU ranks (gloo) end with the same weights, and resume."""
import json
import os
import subprocess
import sys

import pytest
import torch

from conftest import ROOT
from gan_helpers import tiny_dataset

SMALL_RUN = ["train.steps=2", "train.max_train_scenes=0", "train.batch=2", "train.crop=16", "train.eval_every=2",
             "train.checkpoint_every=1", "critic.widths=[8,8]", "generator.widths=[8,8,8]",
             "generator.encoder_blocks=[1,1,1]", "generator.condition_width=4"]


def torchrun(data, out, processes=2):
    command = [sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", str(processes),
               "-m", "gmcpt", "train", "--dataset", str(data), "--out", str(out), "-q"]
    command += [item for setting in SMALL_RUN for item in ("--set", setting)]
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=600,
                            env=dict(os.environ, OMP_NUM_THREADS="1", PYTHONWARNINGS="ignore"))
    assert result.returncode == 0, result.stderr[-3000:]
    return json.loads(result.stdout.strip().splitlines()[-1])


@pytest.mark.slow  # 28 s here: `make test` stays under 15 min; `make test-slow` runs it
def test_two_ranks_train_to_identical_weights_and_resume(tmp_path):
    from gmcpt.gan.distributed import weights_digest
    from gmcpt.gan.train import Trainer, load_config

    data, out = tmp_path / "data", tmp_path / "run"
    tiny_dataset(data)                           # 2 training scenes: one for each rank
    summary = torchrun(data, out)
    assert summary["steps"] == 2 and summary["processes"] == 2
    first, second = summary["rank_weights_sha256"]
    assert first == second                       # the two ranks hold the same weights, bit for bit
    state = torch.load(out / "checkpoint.pt", weights_only=True)
    assert weights_digest(state["generator"], state["critic"]) == first   # and rank 0 wrote them
    assert state["world_size"] == 2 and len(state["rank_torch_rng"]) == 2
    numpy_states = json.loads(state["rank_numpy_rng"])
    assert numpy_states[0] != numpy_states[1]    # each rank drew its own crops
    # a resumed run picks each rank's state up again; one process may not resume a two-process run
    assert torchrun(data, out)["rank_weights_sha256"] == [first, first]
    overrides = dict(item.split("=", 1) for item in SMALL_RUN)
    config = load_config("cpu", {key: json.loads(value) for key, value in overrides.items()} | {"train.dataset": str(data)})
    with pytest.raises(ValueError, match="made by 2 process"):
        Trainer(config, out, lambda message: None).load_checkpoint()


def test_ranks_come_from_the_torchrun_environment():
    from gmcpt.gan.distributed import Ranks, from_environment, seed_sequence, shard

    assert from_environment({}) == Ranks() and not Ranks().distributed
    ranks = from_environment({"RANK": "1", "WORLD_SIZE": "2", "LOCAL_RANK": "1"})
    assert ranks == Ranks(1, 2, 1) and ranks.distributed and not ranks.main
    assert shard(list("abcde"), ranks) == ["b", "d"] and shard(list("abcde"), Ranks(0, 2)) == ["a", "c", "e"]
    assert seed_sequence(1, Ranks()) == [1, 0x7EA1] and seed_sequence(1, ranks) == [1, 0x7EA1, 1]
    for bad in ({"RANK": "2", "WORLD_SIZE": "2"}, {"WORLD_SIZE": "x"}):
        with pytest.raises(ValueError):
            from_environment(bad)
    with pytest.raises(ValueError, match="cannot be shared by 4"):
        shard(["a"], Ranks(3, 4))
