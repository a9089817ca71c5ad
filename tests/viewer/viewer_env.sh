# Sourced by the viewer's test scripts, with VIEW set to blobcast-view:
# sets VIEWENV, the prefix that runs it. Under AddressSanitizer, Mesa's DRI
# driver is unloaded when GLFW ends and LeakSanitizer then reports the
# driver's own allocations as leaks from an "<unknown module>". Keeping the
# driver loaded makes them reachable; leaks of ours are still reported.
VIEWENV=
if ldd "$VIEW" 2>/dev/null | grep -q libasan; then
  for d in /usr/lib/x86_64-linux-gnu/dri /usr/lib/*/dri /usr/lib/dri; do
    if [ -f "$d/swrast_dri.so" ]; then
      VIEWENV="env ASAN_OPTIONS=verify_asan_link_order=0 \
LD_PRELOAD=$d/swrast_dri.so"
      break
    fi
  done
fi
