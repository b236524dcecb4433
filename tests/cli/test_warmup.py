"""``hammerstein warmup``: every compiled kernel of the package is reached once."""

import numba

from hammerstein.cli.main import main
from hammerstein.identification import _creep_kernels, _gpi_sensitivity
from hammerstein.simulation import _kernels, _preisach


def _public_kernels():
    """The entry kernels: numba dispatchers of the kernel modules not named with a leading _."""
    out = {}
    for mod in (_kernels, _preisach):
        for name, obj in vars(mod).items():
            if isinstance(obj, numba.core.registry.CPUDispatcher) and not name.startswith("_") \
                    and obj.__module__ == mod.__name__:
                out[f"{mod.__name__}.{name}"] = obj
    return out


def test_warmup_reaches_every_entry_kernel(capsys):
    assert main(["warmup"]) == 0, capsys.readouterr().err
    printed = capsys.readouterr().out
    assert "warmup:" in printed and "kernel(s) compiled" in printed
    kernels = _public_kernels()
    assert len(kernels) >= 8
    # loaded from the cache or compiled: either way the dispatcher now holds a signature
    # (_preisach.ramps is only called by other kernels, which link it: never loaded alone)
    missing = [name for name, d in kernels.items() if not d.signatures and not name.endswith(".ramps")]
    assert not missing, missing
    # the identification's own kernels (private, each called by its module's wrapper; the
    # helpers they inline, such as _play_step, are never loaded alone)
    ident = {f"{mod.__name__}.{name}": obj for mod in (_gpi_sensitivity, _creep_kernels)
             for name, obj in vars(mod).items()
             if isinstance(obj, numba.core.registry.CPUDispatcher) and obj.__module__ == mod.__name__
             and name.endswith("_kernel")}
    assert len(ident) >= 4
    assert not [name for name, d in ident.items() if not d.signatures]


def test_second_warmup_compiles_nothing(capsys):
    assert main(["warmup", "-q"]) == 0
    assert main(["warmup"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[-1].startswith("warmup: 0 kernel(s) compiled"), lines
