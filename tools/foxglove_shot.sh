#!/usr/bin/env bash
# A screenshot of the Foxglove app (Foxglove Studio 1.48, its web build) drawing a pacc
# recording through a layout, in Debian's chromium driven by Playwright. A maintainer's tool,
# not part of CI (it downloads 36 MB of npm packages and takes about a minute).
#
#   pacc drive --scenario B --driver d3 --controller predefined+oa --seed 1 --can-log drive.mcap
#   tools/foxglove_shot.sh drive.mcap docs/foxglove-layout.json shot.png
#   tools/foxglove_shot.sh ws://127.0.0.1:8765 docs/foxglove-layout.json live.png   # --foxglove
#
# The app: npm's @foxglove/studio-base 1.48.0 (MPL-2.0), the last open-source Foxglove Studio
# published prebuilt (a webpack bundle of the whole app that takes React 17 from the page), in
# tools/foxglove_host.html, a page doing what Studio's web shell did. FOX_DIR (default
# /tmp/pacc-foxglove) keeps the packages between runs; PYTHON (default .venv/bin/python) must
# have playwright. How it was used for docs/foxglove.png: docs/logs.md.
set -euo pipefail
src=$1 layout=$(realpath "$2") shot=$(realpath -m "$3")
repo=$(cd "$(dirname "$0")/.." && pwd)
cache=${FOX_DIR:-/tmp/pacc-foxglove}
py=${PYTHON:-$repo/.venv/bin/python}
mkdir -p "$cache"
for spec in @foxglove/studio-base@1.48.0 react@17.0.2 react-dom@17.0.2; do
  name=${spec%@*} name=${name#@} name=${name//\//-}
  dir="$cache/$name"
  if [ ! -d "$dir/package" ]; then
    tgz=$(cd "$cache" && npm pack --silent "$spec" 2>/dev/null | tail -1)
    mkdir -p "$dir" && tar xzf "$cache/$tgz" -C "$dir" && rm "$cache/$tgz"
  fi
done
web=$(mktemp -d)
trap 'rm -rf "$web"' EXIT
cp "$repo/tools/foxglove_host.html" "$web/index.html"
cp "$cache/react/package/umd/react.production.min.js" "$web/"
cp "$cache/react-dom/package/umd/react-dom.production.min.js" "$web/"
ln -s "$cache/foxglove-studio-base/package" "$web/studio-base"
if [[ $src != ws://* ]]; then
  cp "$src" "$web/" && src=$(basename "$src")
fi
cp "$layout" "$web/$(basename "$layout")"
cd "$repo"
nice -n 5 "$py" -m tools.foxglove_shot "$web" "$src" "$(basename "$layout")" "$shot"
