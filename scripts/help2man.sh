#!/usr/bin/env bash
# Writes the man pages of the ffd command from its own --help text, so that
# the two never disagree: OUTDIR/ffd.1 from `ffd --help`, and ffd-CMD.1 from
# `ffd CMD --help` for every command that `ffd --help` lists. Run by the
# build (CMake target ffd_man); docs/cli.md "Manual pages".
# usage: scripts/help2man.sh PATH_TO_ffd OUTDIR
set -euo pipefail
FFD=$1
OUT=$2
mkdir -p "$OUT"
rm -f "$OUT"/ffd.1 "$OUT"/ffd-*.1 # a command that is gone loses its page
version=$("$FFD" --version | awk '{print $2}')

# help2roff NAME SUMMARY: the help text on stdin as a man(7) page on stdout.
# The help's layout: "usage:" lines (the synopsis), paragraphs, then sections
# "NAME:" whose entries are "  TERM  DESCRIPTION" (TERM alone on a line when
# long) and continuation lines indented to the description's column.
help2roff() {
    awk -v name="$1" -v summary="$2" -v version="$version" '
    function esc(s) { gsub(/\\/, "\\e", s); gsub(/-/, "\\-", s); return s }
    function line(s) { s = esc(s); if (s ~ /^[.\x27]/) s = "\\&" s; print s }
    function flush_entry() {
        if (term != "") { print ".TP"; print "\\fB" esc(term) "\\fR"; if (desc != "") line(desc) }
        term = ""; desc = ""
    }
    BEGIN {
        upper = toupper(name)
        print ".TH " upper " 1 \"\" \"ffd " version "\" \"ffd manual\""
        print ".nh"; print ".ad l"
        print ".SH NAME"; line(name " - " summary)
        state = "start"
    }
    state == "start" && /^usage: / { print ".SH SYNOPSIS"; state = "usage" }
    state == "usage" {
        if ($0 == "") { print ".SH DESCRIPTION"; state = "text"; next }
        s = $0; sub(/^(usage: |       )/, "", s); print ".br"; line(s); next
    }
    /^[A-Za-z][^:]*:$/ && (state == "text" || state == "section") {
        flush_entry(); h = $0; sub(/:$/, "", h); print ".SH " toupper(esc(h)); state = "section"; col = 0; next
    }
    state == "text" { if ($0 == "") print ".PP"; else line($0); next }
    state == "section" {
        if ($0 == "") { flush_entry(); print ".PP"; state = "text"; next }
        if ($0 ~ /^  [^ ]/) {
            flush_entry()
            s = substr($0, 3)
            if (match(s, /   *[^ ]/)) {
                term = substr(s, 1, RSTART - 1); desc = substr(s, RSTART + RLENGTH - 1)
                if (!col) col = RSTART + RLENGTH + 1
            } else if (col && length($0) >= col && substr($0, col - 1, 1) == " ") {
                # a term that fills its column up to one space
                term = substr($0, 3, col - 4); desc = substr($0, col)
            } else { term = s; desc = "" }
            next
        }
        # a continuation: the term'"'"'s part left of the description column, then the description
        s = $0; t = ""; d = s
        if (col && length(s) >= col && substr(s, col - 2, 2) == "  ") { t = substr(s, 1, col - 1); d = substr(s, col) }
        else if (col && length(s) < col) { t = s; d = "" }
        sub(/^ +/, "", t); sub(/ +$/, "", t); sub(/^ +/, "", d)
        if (t != "") term = term " " t
        if (d != "") desc = desc == "" ? d : desc " " d
        next
    }
    END { flush_entry() }'
}

# The commands and their one-line summaries, from the top-level help: an
# entry starts with "  NAME "; its summary is the text from column 42 on.
"$FFD" --help >"$OUT/.help"
awk '
    /^commands:/ { on = 1; next }
    on && /^$/ { on = 0 }
    on && /^  [a-z]/ { if (name != "") print name "\t" sum; name = $1; sum = "" }
    on && length($0) > 41 && substr($0, 40, 2) == "  " {
        s = substr($0, 42); sub(/^ +/, "", s); sum = sum == "" ? s : sum " " s
    }
    END { if (name != "") print name "\t" sum }' "$OUT/.help" >"$OUT/.commands"

help2roff ffd "free-form deformation of triangle and polygon meshes" <"$OUT/.help" >"$OUT/ffd.1.tmp"
{
    cat "$OUT/ffd.1.tmp"
    printf '.SH SEE ALSO\n'
    sep=""
    while IFS=$'\t' read -r cmd _; do printf '%s\\fBffd\\-%s\\fR(1)' "$sep" "$cmd"; sep=", "; done <"$OUT/.commands"
    printf '\n'
} >"$OUT/ffd.1"
rm -f "$OUT/ffd.1.tmp"
while IFS=$'\t' read -r cmd summary; do
    "$FFD" "$cmd" --help | help2roff "ffd-$cmd" "$summary" >"$OUT/ffd-$cmd.1"
    printf '.SH SEE ALSO\n\\fBffd\\fR(1)\n' >>"$OUT/ffd-$cmd.1"
done <"$OUT/.commands"
rm -f "$OUT/.help" "$OUT/.commands"
