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
echo "   (${SECONDS} s since the start)"

# One optimised build serves every test: the Rust tests run on the release profile with debug
# assertions and overflow checks on, and the add-on tests use that same binary
# (target/release/prism; run_addon_tests.sh's `cargo build --release` then has nothing to do).
# A full compile is about 7 minutes on a 2-core machine: building twice would not fit CI's budget.
export CARGO_PROFILE_RELEASE_DEBUG_ASSERTIONS=true CARGO_PROFILE_RELEASE_OVERFLOW_CHECKS=true
# The release profile's whole-program LTO would be paid by every test binary's link.
export CARGO_PROFILE_RELEASE_LTO=false CARGO_PROFILE_RELEASE_CODEGEN_UNITS=16

echo "== Rust unit, statistical, image and CLI tests"
# The benches are type-checked by clippy above; building them in release would add their
# harness (criterion) to the compile for nothing.
cargo test --release --lib --bins --tests
echo "   (${SECONDS} s since the start)"

echo "== Blender add-on tests (bpy wheel 5.0.1 and Debian's blender -b; installs them if missing)"
tests/addon/run_addon_tests.sh
