"""Errors survive copying and pickling unchanged (the debugger's checkpoints and Machine.snapshot
copy a machine that may hold the error its run ended with)."""

from __future__ import annotations

import copy
import pickle

from netsushisen.emulator.core import RunFault
from netsushisen.emulator.machine import DeadlockError
from netsushisen.isa.errors import ConfigError, Diagnostic, NetsushisenError


def test_errors_copy_and_pickle_by_state():
    errors = [NetsushisenError("plain"), ConfigError(Diagnostic("bad", file="c.toml", line=3)),
              RunFault("pe0.ic", 42, "load outside memory", pc=7),
              DeadlockError([Diagnostic("deadlock"), Diagnostic("fifo pe0.recv.os: 64/64")])]
    for err in errors:
        for clone in (copy.deepcopy(err), pickle.loads(pickle.dumps(err))):
            assert type(clone) is type(err)
            assert clone.format() == err.format()
            assert clone.exit_code == err.exit_code
            assert clone.__dict__.keys() == err.__dict__.keys()
