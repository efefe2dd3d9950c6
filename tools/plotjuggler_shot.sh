#!/usr/bin/env bash
# A screenshot of PlotJuggler showing a pacc recording through its layout, on a virtual screen.
#
#   pacc plot drive.mcap --plotjuggler drive.xml
#   tools/plotjuggler_shot.sh drive.xml shot.png [TAB]
#
# PLOTJUGGLER (default: plotjuggler on PATH) and PJ_PLUGINS (a folder of PlotJuggler plugins,
# default none beyond its own) say which build to run. TAB 1 shows the layout's CAN tab.
# Needs Debian's xvfb and imagemagick. How PlotJuggler was built for docs/plotjuggler.png: docs/logs.md.
set -euo pipefail
layout=$1 shot=$2 tab=${3:-0}
pj=${PLOTJUGGLER:-plotjuggler}
dir=$(mktemp -d)
trap 'rm -rf "$dir"' EXIT
# the same layout, opened on the tab asked for, beside the original (the data file is relative)
view="$(dirname "$layout")/.shot-$(basename "$layout")"
sed "s/<currentTabIndex index=\"[0-9]*\"/<currentTabIndex index=\"$tab\"/" "$layout" > "$view"
export DISPLAY=:${PJ_DISPLAY:-77}
Xvfb "$DISPLAY" -screen 0 1600x1000x24 >/dev/null 2>&1 &
xvfb=$!
sleep 1
args=(--nosplash --disable_opengl -l "$view")
[ -n "${PJ_PLUGINS:-}" ] && args+=(--plugin_folders "$PJ_PLUGINS")
"$pj" "${args[@]}" > "$dir/plotjuggler.log" 2>&1 &
app=$!
sleep "${PJ_WAIT_S:-12}"
import -window root -crop 1060x832+0+0 +repage "$shot"
kill "$app" "$xvfb" 2>/dev/null || true
rm -f "$view"
grep -q "Loaded file" "$dir/plotjuggler.log" || { cat "$dir/plotjuggler.log" >&2; exit 1; }
echo "screenshot: $shot"
