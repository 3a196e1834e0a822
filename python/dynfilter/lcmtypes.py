"""The LCM message classes (``reference_frame_t``, ``contact_state_t``, ...) beside the
bindings.

lcm-gen generates them as a package also called ``dynfilter`` (``build/lcmtypes/python``,
README "LCM messages"), which is not installed by ``pip install .``. With that directory on
``sys.path`` after the bindings, ``import dynfilter.lcmtypes`` makes every message class an
attribute of this module and of ``dynfilter`` (as lcm-gen's own ``__init__`` does, which the
generated decoders rely on: ``dynfilter.contact_t._decode_one``). The LCM tools
(tools/plot_lcm_log.py, tests/lcm/python_types_check.py) keep importing lcm-gen's package
directly, with its directory first on ``sys.path``.
"""
import importlib
import pkgutil
from pathlib import Path

import dynfilter as _package

_package.__path__ = pkgutil.extend_path(_package.__path__, "dynfilter")
__all__ = sorted({f.stem for d in _package.__path__ for f in Path(d).glob("*_t.py")})
if not __all__:
    raise ImportError("no LCM message types: put build/lcmtypes/python on sys.path "
                      "(after the bindings)")
_classes = {name: getattr(importlib.import_module("dynfilter." + name), name) for name in __all__}
for _name, _cls in _classes.items():
    setattr(_package, _name, _cls)
    globals()[_name] = _cls
