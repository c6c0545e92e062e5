#!/usr/bin/env bash
# Runs TestGUI.py in the ParaView GUI under a virtual X server and fails unless the script
# reported success (ParaView's --script exits 0 even when the script raises).
set -u
paraview_executable="$1"
script="$2"
export STM_GUI_MARKER="$STM_TEMP_DIR/gui-passed"
rm -f "$STM_GUI_MARKER"
timeout 300 xvfb-run -a -s "-screen 0 1280x1024x24" "$paraview_executable" --script="$script" --exit
status=$?
if [ ! -f "$STM_GUI_MARKER" ]; then
  echo "RunGUITest: the GUI script did not report success (ParaView exit status $status)"
  exit 1
fi
echo "RunGUITest: passed"
