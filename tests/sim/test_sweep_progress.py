"""A sweep's progress says when it waits for the compiled kernel (seconds on first use)."""

from __future__ import annotations

import builtins

import fl_design as fl


def test_progress_names_the_kernel_preparation(pendulum, pendulum_design, tmp_path, capsys,
                                               monkeypatch):
    real_import = builtins.__import__

    def no_tqdm(name, *args, **kwargs):  # the plain counter on stderr (no tqdm)
        if name.startswith("tqdm"):
            raise ImportError(name)
        return real_import(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_tqdm)
    smap = fl.sweep(pendulum, pendulum_design(), fl.Scenario(0.05, 0.5), eps=[0.02, 0.2],
                    gamma=[0.01], kernel=fl.Kernel(cache_dir=tmp_path), progress=True)
    err = capsys.readouterr().err
    assert "sweep: preparing the compiled kernel" in err
    assert err.rstrip().endswith("sweep: 2/2 runs")
    assert smap.status.shape == (2, 1)
    fl.sweep(pendulum, pendulum_design(), fl.Scenario(0.05, 0.5), eps=[0.02], gamma=[0.01],
             kernel=fl.Kernel(compiled=False), progress=True)
    assert "compiled kernel" not in capsys.readouterr().err  # the interpreter compiles nothing
