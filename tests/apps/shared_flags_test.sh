#!/usr/bin/env bash
# `commerge run` and `commerge server` share the merge server's flags (apps/merge_flags.hpp): each flag's help
# entry (type, range, default, help text) must be the same in both, and the defaults must be the documented ones:
# stage A ours (core/agent/merge_server.hpp ServerStageADefaults: neighbour rank 1, half window 4, tau_area 400
# cells scaled by 0.3 for short missions, tau_inter 0.5 as a cap), an ambiguous place needs a consensus support of
# 40 keyframes to be registered and 100 to be widened (--widen-ambiguous-support 100), a pair checked against
# chains through a third robot 40, each robot asked for scans holding 3 000 stored points per pair and no count
# floor (--min-submap-stored-points 3000, --min-submap-scans 0), submaps at one voxel size unless asked
# (--min-submap-points 0), a registration
# refused when the keyframes it places together (at least 20) rank no better than a median chance of 0.2 by
# descriptor, tau_con the paper's 5 m.
# Usage: shared_flags_test.sh COMMERGE [EMULATOR...]   (the command that runs the commerge executable)
set -euo pipefail
entry() {  # $1 = help text, $2 = flag: the flag's line and its indented continuation lines
  awk -v flag="$2" '
    $1 == flag { on = 1; print; next }
    on && /^  --/ { exit }
    on && /^[^ ]/ { exit }
    on { print }' <<<"$1"
}
run_help=$("$@" run --help)
server_help=$("$@" server --help)
status=0
flags=(--tau-inter --tau-area --sequence-half-window --neighbour-rank --tau-area-fraction --tau-con-m --min-submap-scans
       --min-submap-stored-points --max-widen-steps --min-ambiguous-support --widen-ambiguous-support --min-submap-points --chain-check-support
       --max-colocated-chance --min-colocated-keyframes --disagree-odds --stage-b-max-nodes --stage-c-max-nodes)
for flag in "${flags[@]}"; do
  a=$(entry "$run_help" "$flag")
  b=$(entry "$server_help" "$flag")
  if [[ -z $a ]]; then echo "run --help lacks $flag"; status=1; continue; fi
  if [[ $a != "$b" ]]; then
    printf 'run and server differ on %s:\n  run:    %s\n  server: %s\n' "$flag" "$a" "$b"
    status=1
  fi
done
for expect in "--tau-inter =0.5" "--tau-area =400" "--sequence-half-window =4" "--neighbour-rank =1" "--tau-area-fraction =0.3" \
              "--tau-con-m =5" "--min-ambiguous-support =40" "--min-submap-scans =0" "--min-submap-stored-points =3000" \
              "--widen-ambiguous-support =100" "--min-submap-points =0" "--chain-check-support =40" \
              "--max-colocated-chance =0.2" "--min-colocated-keyframes =20" "--disagree-odds =100" \
              "--stage-b-max-nodes =20000" "--stage-c-max-nodes =2000000"; do
  flag=${expect%% *}
  value=${expect#* }
  line=$(entry "$run_help" "$flag" | head -n 1)
  if [[ $line != *"$value" ]]; then echo "$flag: default is not the documented ${value#=}: $line"; status=1; fi
done
[[ $status -eq 0 ]] && echo "run and server share ${#flags[@]} merge flags with identical help and the documented defaults"
exit $status
