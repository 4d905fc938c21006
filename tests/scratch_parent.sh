#!/bin/sh
# scratch_parent.sh: prints the folder the test scripts that start hundreds of step processes
# keep their scratch files in (mktemp -d -p "$(sh tests/scratch_parent.sh)"): /dev/shm when it
# is a memory file system (tmpfs) with 256 MiB free and TMPDIR is not set, else TMPDIR or
# /tmp. The same choice as tests/harness.h's scratch_parent(): creating, renaming and removing
# each run's files on a disk's file system (ext4) was ~15% of such a test's CPU time.
least_free_kib=262144
if [ -z "${TMPDIR:-}" ] && [ "$(stat -f -c %T /dev/shm 2> /dev/null)" = tmpfs ] &&
        [ -w /dev/shm ] &&
        [ "$(df -Pk /dev/shm 2> /dev/null | awk 'NR == 2 { print $4 }')" -ge $least_free_kib ] \
        2> /dev/null; then
    echo /dev/shm
else
    echo "${TMPDIR:-/tmp}"
fi
