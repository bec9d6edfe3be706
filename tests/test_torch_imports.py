"""``import motionrep``, the command line, the readers and every decoder never import torch (only
motionrep.torch does); checked in a fresh interpreter, whether or not torch is installed."""

from __future__ import annotations

import subprocess
import sys
import textwrap

from helpers import REPO

_SCRIPT = textwrap.dedent("""
    import sys
    import motionrep, motionrep.cli, motionrep.io, motionrep.testing
    import motionrep_dualquat, motionrep_euler, motionrep_ortho6d, motionrep_rootquat
    from click.testing import CliRunner
    from motionrep.plugin.registry import codecs, representations
    from motionrep.model.synthetic import synthetic_motion
    m = synthetic_motion(frames=6, seed=0)
    for rep in representations().values():
        rep.from_features(rep.to_features(m), m.skeleton, m.fps)
    codecs()
    motionrep.io.write(m, sys.argv[1])
    motionrep.io.read(sys.argv[1])
    for args in (["plugins"], ["info", sys.argv[1]], ["evaluate", sys.argv[1], sys.argv[1]]):
        result = CliRunner().invoke(motionrep.cli.cli, args)
        assert result.exit_code == 0, (args, result.output)
    print(sorted(n for n in sys.modules if n == "torch" or n.startswith("torch.") or n == "roma"))
""")


def test_motionrep_cli_readers_and_decoders_never_import_torch(tmp_path):
    out = subprocess.run([sys.executable, "-c", _SCRIPT, str(tmp_path / "clip.bvh")], capture_output=True, text=True,
                         cwd=REPO, env=_env(), timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]", out.stdout


def _env():
    import os

    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(REPO), str(REPO / "plugins"), env.get("PYTHONPATH", "")])
    env["MOTIONREP_LOAD_PLUGINS"] = ""
    return env
