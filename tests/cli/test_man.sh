#!/usr/bin/env bash
# The man pages (docs/cli.md "Manual pages"): scripts/help2man.sh makes one
# page for ffd and one per command its --help lists; each renders with groff
# without a warning, holds every option its command's --help names, and the
# pages the build made (man/ in the build directory) are the ones the
# current --help texts give.
# usage: bash test_man.sh PATH_TO_ffd SOURCE_DIR   (run in the build directory)
set -u
source "$(dirname "$0")/lib.sh" "$1" "$2"
if ! command -v groff >/dev/null 2>&1; then
    echo "note: groff is not installed (Debian groff-base): man pages not rendered; skipped"
    exit 0
fi
bash "$SRC/scripts/help2man.sh" "$FFD" "$T/man" || fail "help2man.sh failed"

commands=$("$FFD" --help | awk '/^commands:/ { on = 1; next } on && /^$/ { on = 0 } on && /^  [a-z]/ { print $1 }')
[ -n "$commands" ] || fail "no commands in ffd --help"
for cmd in "" $commands; do
    page=$T/man/ffd${cmd:+-$cmd}.1
    name=ffd${cmd:+ $cmd}
    if [ ! -s "$page" ]; then
        fail "$name: no man page $page"
        continue
    fi
    groff -man -Tascii -ww -P-cbou "$page" >"$T/text" 2>"$T/warnings" || fail "$name: groff failed"
    [ -s "$T/warnings" ] && fail "$name: groff warnings: $(head -5 "$T/warnings")"
    grep -q "^NAME" "$T/text" || fail "$name: no NAME section"
    # every option of the help text (long and short) is in the rendered page
    # shellcheck disable=SC2086
    "$FFD" $cmd --help >"$T/help" || fail "$name --help failed"
    flat=$(tr -s ' \n' '  ' <"$T/text")
    for opt in $(grep -oE -- '(^|[ ,[|])--?[a-z][a-z0-9-]*' "$T/help" | sed 's/^[ ,[|]//' | sort -u); do
        case "$flat" in
        *"$opt"*) ;;
        *) fail "$name: the man page lacks option $opt of its --help" ;;
        esac
    done
    # the build's page is the one the current help gives
    if [ -d man ]; then
        cmp -s "$page" "man/$(basename "$page")" || fail "$name: build/man/$(basename "$page") is stale"
    fi
done

[ "$failures" -eq 0 ] && echo "cli man pages: all passed"
exit $((failures > 0))
