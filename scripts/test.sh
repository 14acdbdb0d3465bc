#!/usr/bin/env bash
# Runs every test of the project. Installs what the tests need on a fresh machine.
# Usage: scripts/test.sh            (everything)
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== installing what the tests need (bpy wheel with its OIDN, Debian's blender, xvfb)"
tests/addon/run_addon_tests.sh install

echo "== cargo fmt / clippy"
cargo fmt --all -- --check
cargo clippy --all-targets -- -D warnings

echo "== Rust unit, statistical, image and CLI tests"
cargo test --all-targets

echo "== Blender add-on tests (bpy wheel 5.0.1 and Debian's blender -b; installs them if missing)"
tests/addon/run_addon_tests.sh
