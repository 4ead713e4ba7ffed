# Sourced by the peer bench scripts (benches/models, benches/mrcal, benches/peers): finds the
# calib binary and the revision it was built from, written once.
#
# In: ROOT (repository root), CALIB (a binary given with --calib, or empty), BUILD (1: run
# cargo build --release first), and a `die` function. Out: CALIB (the binary) and CALIB_REV
# (the short revision, "+dirty" if crates/ or the Cargo files have uncommitted changes).
if [[ -z "$CALIB" ]]; then
    TARGET_DIR="${CARGO_TARGET_DIR:-target}"
    [[ "$TARGET_DIR" = /* ]] || TARGET_DIR="$ROOT/$TARGET_DIR"
    CALIB="$TARGET_DIR/release/calib"
    if [[ $BUILD -eq 1 ]]; then
        echo "== cargo build --release -p calib-cli"
        cargo build --release -p calib-cli || die "cargo build --release -p calib-cli failed"
    fi
fi
[[ -x "$CALIB" ]] || die "calib binary not found at $CALIB (build with: cargo build --release -p calib-cli)"
CALIB_REV="$(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo unknown)"
if [[ -n "$(git -C "$ROOT" status --porcelain -- crates Cargo.toml Cargo.lock 2>/dev/null)" ]]; then
    CALIB_REV+="+dirty"
fi
