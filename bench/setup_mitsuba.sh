#!/usr/bin/env bash
# Installs Mitsuba 3 into bench/.venv and Debian's LLVM for the llvm_ad_rgb variant.
set -euo pipefail
cd "$(dirname "$0")"
python3 -m venv .venv
.venv/bin/pip install -q mitsuba
# Dr.Jit's LLVM backend needs a recent LLVM; older ones on the machine are
# rejected at run time, so install 19 explicitly.
if ! ls /usr/lib/x86_64-linux-gnu/libLLVM-19.so* >/dev/null 2>&1; then
  (apt-get install -y -q libllvm19 || (apt-get update -q && apt-get install -y -q libllvm19)) >/dev/null
fi
