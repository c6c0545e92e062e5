#!/usr/bin/env bash
# Runs the ParaView GUI under a virtual X server with the given arguments (a --script, or --data
# and a --test-script playback) and fails unless the test's Python reported success by writing
# the marker file STM_GUI_MARKER: ParaView exits 0 even when the script raises.
# Usage: RunGUITest.sh PARAVIEW_EXECUTABLE PARAVIEW_ARGUMENTS...
set -u
paraview_executable="$1"
shift
export STM_GUI_MARKER="$STM_TEMP_DIR/gui-passed"
rm -f "$STM_GUI_MARKER" "$STM_GUI_MARKER.failure"
# Settings of its own, so that neither the user's settings nor the welcome dialog, which is
# modal on a first start and stops a playback, get in the way.
export XDG_CONFIG_HOME="$STM_TEMP_DIR/config"
rm -rf "$XDG_CONFIG_HOME"
mkdir -p "$XDG_CONFIG_HOME/ParaView"
printf '[General]\nGeneralSettings.ShowWelcomeDialog=0\n' >"$XDG_CONFIG_HOME/ParaView/ParaView5.11.0.ini"
timeout 300 bash "$(dirname "$0")/RunUnderXvfb.sh" "$paraview_executable" "$@" --exit
status=$?
if [ -f "$STM_GUI_MARKER.failure" ]; then
  cat "$STM_GUI_MARKER.failure"
fi
if [ ! -f "$STM_GUI_MARKER" ]; then
  echo "RunGUITest: the GUI test did not report success (ParaView exit status $status)"
  exit 1
fi
echo "RunGUITest: passed"
