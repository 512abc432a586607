#!/bin/bash
# Proves that every per-ISA kernel object (runtime/kernels/<isa>/*.o, except the plain C++ ref/)
# defines external symbols only in its own namespace dp::kernels::<isa>: an inline helper compiled
# with AVX-512 (or NEON) flags and visible to the linker could be the copy every other caller gets
# (an illegal instruction on a CPU without that ISA, at -O0 where nothing inlines).
# Usage: NM=nm mk/check_isa_linkage.sh BUILD/obj/runtime/kernels
set -eu
dir=${1:?usage: check_isa_linkage.sh OBJ_DIR}
nm=${NM:-nm}
bad=0
checked=0
for obj in "$dir"/*/*.o; do
  [ -e "$obj" ] || continue
  isa=$(basename "$(dirname "$obj")")
  [ "$isa" = ref ] && continue
  checked=$((checked + 1))
  leaks=$("$nm" -C --defined-only --extern-only "$obj" | awk '{ $1 = ""; $2 = ""; sub(/^  /, ""); print }' |
          grep -v -E "^dp::kernels::$isa::" || true)
  if [ -n "$leaks" ]; then
    echo "check-isa-linkage: $obj exports symbols outside dp::kernels::$isa::"
    echo "$leaks" | sed 's/^/    /'
    bad=1
  fi
done
if [ "$checked" -eq 0 ]; then echo "check-isa-linkage: FAILED: no ISA kernel objects under $dir"; exit 1; fi
if [ "$bad" -ne 0 ]; then echo "check-isa-linkage: FAILED"; exit 1; fi
echo "check-isa-linkage: OK ($checked ISA kernel objects export only their own namespace)"
