import pytest

from gmcpt.runtime import llvm
from gmcpt.errors import GmcptError


def test_user_setting_is_respected(monkeypatch):
    monkeypatch.setenv("DRJIT_LIBLLVM_PATH", "/custom/libLLVM.so")
    assert llvm.configure_llvm() == "/custom/libLLVM.so"


def test_newest_suitable_version_wins(monkeypatch):
    found = ["/usr/lib/x86_64-linux-gnu/libLLVM-15.so", "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
             "/usr/lib/x86_64-linux-gnu/libLLVM-17.so"]
    monkeypatch.setattr(llvm.glob, "glob", lambda pattern: found if "x86_64" in pattern else [])
    assert llvm.find_libllvm().endswith("libLLVM-19.so")


def test_old_llvm_only_gives_install_hint(monkeypatch):
    monkeypatch.delenv("DRJIT_LIBLLVM_PATH", raising=False)
    monkeypatch.setattr(llvm.glob, "glob", lambda pattern: ["/usr/lib/x86_64-linux-gnu/libLLVM-14.so"]
                        if "x86_64" in pattern else [])
    with pytest.raises(GmcptError, match="apt-get install libllvm19"):
        llvm.require_llvm()
