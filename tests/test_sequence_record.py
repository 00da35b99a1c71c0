"""The sequence benchmark's record read back (gmcpt.evaluation.sequences): figures at equal time, the plot's ceiling,
the line at a glance and the results' section."""
import numpy as np
import pytest

from gmcpt.evaluation.sequences import ceiling, equal_time_gap, equal_time_ratio, glance_line


def _row(contender, spp, seconds, **figures):
    return {"scene": "living-room", "motion": "object", "contender": contender, "rate": 1.0, "spp": spp,
            "seconds": seconds, **figures}


#: a baseline measured at 0.1 and 0.4 s a frame; the sequence between them and past the slower
ROWS = [_row("path+oidn", 1, 0.1, flicker=8.0, psnr_changed=20.0),
        _row("path+oidn", 4, 0.4, flicker=4.0, psnr_changed=24.0),
        _row("sequence", 1, 0.2, flicker=3.0, psnr_changed=21.0),
        _row("sequence", 4, 0.8, flicker=2.0, psnr_changed=26.0)]


def test_equal_time_figures_read_the_baseline_in_log_time_and_hold_it_past_its_ends():
    """At 0.2 s (the log-midpoint of 0.1 and 0.4) the baseline's flicker is 6 and its PSNR 22; at 0.8 s, past its
    slowest setting, 4 and 24."""
    assert equal_time_ratio(ROWS, "path+oidn") == pytest.approx(np.sqrt(3 / 6 * 2 / 4))
    assert equal_time_gap(ROWS, "path+oidn") == pytest.approx(((21 - 22) + (26 - 24)) / 2)


def test_equal_time_figures_leave_out_what_was_not_measured():
    """A still scene has no changed pixels: no gap; a baseline that did not run: no ratio."""
    still = [dict(r, psnr_changed=None) for r in ROWS]
    assert equal_time_gap(still, "path+oidn") is None
    assert equal_time_ratio(ROWS, "accumulation+oidn") is None


def test_the_ceiling_is_path_tracing_at_7_6_times_the_sequences_samples_at_the_sequences_seconds():
    rows = [_row("path+oidn", spp, 0.05 * spp, psnr=20 + 2 * np.log2(spp)) for spp in (1, 2, 4, 8, 16, 32)]
    rows += [_row("sequence", 1, 0.3, psnr=25.0), _row("sequence", 8, 0.9, psnr=27.0)]
    (first, top_1), (second, top_8) = ceiling(rows)
    assert (first, second) == (0.3, 0.9)
    assert top_1 == pytest.approx(20 + 2 * np.log2(7.6))
    assert top_8 == pytest.approx(30.0)  # 61 samples: held at path tracing's most, 32
    assert ceiling([r for r in rows if r["contender"] == "sequence"]) == []


def _verdict(motion, speedup, flicker):
    return {"scene": "dining-room", "motion": motion, "baseline": "path+oidn", "speedup": speedup, "bounds": 0,
            "settings": 3, "flicker_ratio": flicker, "screen_flicker_ratio": 0.8, "changed_gap_db": -0.5}


SEQUENCES = {"command": "python benchmarks/sequence.py --record x", "date": "2026-12-01", "commit": "abc",
             "machine": "x86_64, 2 CPU cores", "settings": {"frames": 6, "warm": 2, "res": 64, "reference_spp": 64,
                                                           "motion": ["pan", "object"], "step": {"pan": 0.5}},
             "moving": {"dining-room": {"pan": "the camera, 0.5 degrees a frame", "object": "Mesh010.obj"}},
             "rows": [dict(_row("sequence", 1, 0.2, psnr=24.0, flip=0.1, flicker=3.0, screen_flicker=4.0,
                                psnr_changed=21.5, changed_share=0.032), scene="dining-room"),
                      dict(_row("path+oidn", 1, 0.1, psnr=22.0, flip=0.12, flicker=8.0, screen_flicker=9.0,
                                psnr_changed=None, changed_share=0.0), scene="dining-room", motion="pan")],
             "verdicts": [_verdict("pan", 1.9, 0.4), _verdict("dolly", 1.2, 0.9), _verdict("object", 0.8, 0.7),
                          _verdict("light", 1.1, 0.6)]}


def test_the_line_at_a_glance_gives_the_speedups_on_camera_and_on_scene_motion_and_the_flicker():
    line = glance_line(SEQUENCES)
    assert "1.20-1.90x on pans and dollies" in line and "0.80-1.10x on moving objects and lights" in line
    assert "flicker 0.40-0.90x of that baseline's" in line and "1 scenes at 64x64" in line
    assert "accumulation" not in line  # no verdict against it in this record
    against = dict(SEQUENCES, verdicts=SEQUENCES["verdicts"] + [dict(_verdict("pan", 0.9, 1.2),
                                                                     baseline="accumulation+oidn")])
    line = glance_line(against)
    assert "over accumulation + OIDN 0.90x on pans and dollies" in line and "1.20-1.90x on pans" in line
    assert "light samples" not in line  # nor against per-frame path tracing with the sequence's light samples
    lit = dict(SEQUENCES, verdicts=SEQUENCES["verdicts"] + [dict(_verdict("pan", 1.1, 1.2), baseline="lightpath+oidn")])
    assert "with the sequence's light samples (its estimator alone) 1.10x on pans and dollies" in glance_line(lit)
    old = dict(SEQUENCES, settings={"res": 256, "motion": "pan"},
               verdicts=[{k: v for k, v in _verdict("pan", 1.6, 0.5).items() if k != "motion"}])
    assert "1.60x on pans and dollies (above" in glance_line(old) and "objects" not in glance_line(old)
    still = dict(SEQUENCES, verdicts=SEQUENCES["verdicts"] + [_verdict("still", 2.7, 0.2)])
    line = glance_line(still)
    assert "2.70x with nothing moving" in line and "flicker 0.40-0.90x" in line  # its flicker not in the span


def test_the_results_section_has_a_table_and_verdicts_per_motion_and_the_glance_leads_with_the_sequences():
    from gmcpt.evaluation.document import sequence_section
    from gmcpt.evaluation.glance import glance_section

    text = "\n".join(sequence_section(SEQUENCES))
    pan, obj = text.index("### pan"), text.index("### object")
    assert pan < obj and "(dining-room: Mesh010.obj)." in text[obj:]
    assert "| dining-room | sequence | 1 | 24.00 | 21.50 (3.2%) | 0.1000 | 0.200 | 3.00 (4.00) |" in text[obj:]
    assert "| dining-room | path+oidn | 1 | 22.00 | - | 0.1200 | 0.100 | 8.00 (9.00) |" in text[pan:obj]
    assert "| dining-room | path+oidn | 0.80x | 0.70 (0.80) | -0.50 |" in text[obj:]
    run = {"sequences": SEQUENCES, "config": {"rates": [], "spp": 16}, "equal_time": [], "placement": []}
    opening = glance_section(run)
    assert opening[0] == "## At a glance" and opening[2] == glance_line(SEQUENCES)


def test_a_runs_stages_are_its_warm_frames_means_and_what_no_stage_holds():
    from gmcpt.evaluation.sequences import stage_means

    stages = [{"render_s": 5.0}, {"render_s": 1.0, "denoise_s": 2.0}, {"render_s": 3.0, "denoise_s": 4.0}]
    means = stage_means(stages, [9.0, 4.0, 8.0], warm=1)
    assert means == pytest.approx({"render_s": 2.0, "denoise_s": 3.0, "other_s": 1.0})
    assert stage_means([{}, {}], [1.0, 1.0], warm=0) == {}  # a run that timed no stages


def test_the_results_section_says_where_a_frames_time_goes_at_the_sequences_budgets():
    from gmcpt.evaluation.document import sequence_section

    sequence = {"features_s": 0.030, "render_s": 0.060, "denoise_s": 0.040, "other_s": 0.005}
    baseline = {"render_s": 0.050, "guides_s": 0.010, "denoise_s": 0.040, "other_s": 0.0}
    rows = [_row("sequence", 1, 0.135, psnr=21.0, flicker=3.0, stages=sequence),
            _row("path+oidn", 1, 0.1, psnr=19.0, flicker=8.0, stages=baseline),
            _row("path+oidn", 8, 0.4, psnr=22.0, flicker=5.0, stages=baseline)]  # no sequence at 8: left out
    text = "\n".join(sequence_section(dict(SEQUENCES, rows=rows, verdicts=[])))
    assert "| scene | contender | samples a pixel a frame | survey | path tracing | aov guides | OIDN | other | total |" \
        in text
    assert "| living-room | sequence | 1 | 30 | 60 | - | 40 | 5 | 135 |" in text
    assert "| living-room | path+oidn | 1 | - | 50 | 10 | 40 | 0 | 100 |" in text and "| path+oidn | 8 | -" not in text
    assert "time goes" not in "\n".join(sequence_section(SEQUENCES))  # a record without stages: no table


def test_merged_records_keep_every_scenes_motions(tmp_path):
    """Two runs of one scene's other motions join into one record that still says what moved in each."""
    import json
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
    from sequence import merge

    light = dict(SEQUENCES, command="second", settings=dict(SEQUENCES["settings"], motion=["light"]),
                 moving={"dining-room": {"light": "the sun, 1 degrees a frame"}},
                 verdicts=[_verdict("light", 1.1, 0.6)])
    parts = []
    for index, record in enumerate((dict(SEQUENCES, verdicts=SEQUENCES["verdicts"][:3]), light)):
        parts.append(tmp_path / f"part{index}.json")
        parts[-1].write_text(json.dumps(dict(record, seconds=10.0 * (index + 1),
                                             settings=dict(record["settings"], scenes=["dining-room"]))))
    merge(tmp_path / "merged.json", parts)
    merged = json.loads((tmp_path / "merged.json").read_text())
    assert merged["moving"]["dining-room"] == {"pan": "the camera, 0.5 degrees a frame", "object": "Mesh010.obj",
                                               "light": "the sun, 1 degrees a frame"}
    assert merged["settings"]["scenes"] == ["dining-room"] and len(merged["verdicts"]) == 4
    assert merged["command"].endswith(" && second") and merged["seconds"] == 30.0
    assert (tmp_path / "merged.png").exists()
