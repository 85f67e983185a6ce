#!/bin/busybox sh
# /init of the vcan test VM (copied into the initramfs by vcan_runner.py).
#
# Runs as PID 1 under busybox sh. Loads the modules in /lib/modules (in name
# order), mounts the host's root over virtio-9p on /newroot, runs the job's
# setup.sh (brings up lo and the vcan interfaces) and job.sh (the test command)
# chrooted there, reports the exit status and powers off.
#
# Channels (QEMU serial ports):
#   ttyS0  kernel console + the lines below, read by the runner into a log
#   ttyS1  the command's stdout
#   ttyS2  the command's stderr
# Protocol lines on ttyS0:
#   AACMM_VCAN_STAGE=<name> <uptime>  progress (boot timing)
#   AACMM_VCAN_ERROR=<text>           infrastructure failure, shown to the user
#   AACMM_VCAN_EXIT=<n>               final status (also written to $job/exit)
# Exit status 125 means the infrastructure failed before/around the command.

BB=/bin/busybox
PATH=/bin
export PATH
job=""
mounted=""

stage() {
    echo "AACMM_VCAN_STAGE=$1 $($BB cut -d' ' -f1 /proc/uptime)"
}

finish() {
    rc=$1
    # Stop whatever the command left running (simulators, ...), so that the
    # serial ports get their last close, which drains them.
    $BB kill -TERM -1 2>/dev/null
    $BB usleep 200000
    $BB kill -KILL -1 2>/dev/null
    if [ -n "$mounted" ] && [ -n "$job" ]; then
        echo "$rc" > "/newroot$job/exit.tmp" && $BB mv "/newroot$job/exit.tmp" "/newroot$job/exit"
    fi
    $BB sync
    $BB stty -F /dev/ttyS1 raw -echo 2>/dev/null
    $BB stty -F /dev/ttyS2 raw -echo 2>/dev/null
    echo "AACMM_VCAN_EXIT=$rc"
    $BB poweroff -f
    # Not reached, but never fall off the end of PID 1.
    while :; do $BB sleep 60; done
}

fail() {
    echo "AACMM_VCAN_ERROR=$*"
    $BB dmesg 2>/dev/null | $BB tail -n 8 | $BB sed 's/^/AACMM_VCAN_DMESG=/'
    finish 125
}

$BB mkdir -p /proc /sys /dev /newroot /hosttmp
$BB mount -t proc proc /proc || fail "cannot mount /proc"
$BB mount -t sysfs sysfs /sys || fail "cannot mount /sys"
$BB mount -t devtmpfs devtmpfs /dev || fail "cannot mount devtmpfs"
stage init

for arg in $($BB cat /proc/cmdline); do
    case "$arg" in
        aacmm_job=*) job="${arg#aacmm_job=}" ;;
        aacmm_9p_cache=*) cache="${arg#aacmm_9p_cache=}" ;;
    esac
done
[ -n "$job" ] || fail "no aacmm_job= on the kernel command line"

for m in /lib/modules/*.ko; do
    [ -e "$m" ] || fail "initramfs has no modules"
    out=$($BB insmod "$m" 2>&1) || fail "module ${m##*/} failed to load: $out"
done
stage modules

opts="trans=virtio,version=9p2000.L,msize=262144"
[ -z "${cache:-}" ] || [ "$cache" = none ] || opts="$opts,cache=$cache"
$BB mount -t 9p -o "$opts" hostroot /newroot || fail "cannot mount the host root over 9p ($opts)"
mounted=1
[ -f "/newroot$job/job.sh" ] || fail "job file /newroot$job/job.sh not found in the 9p mount"

$BB mount -t proc proc /newroot/proc || fail "cannot mount proc in the chroot"
$BB mount -t sysfs sysfs /newroot/sys || fail "cannot mount sysfs in the chroot"
$BB mount -t devtmpfs devtmpfs /newroot/dev || fail "cannot mount devtmpfs in the chroot"
$BB mkdir -p /newroot/dev/shm /newroot/dev/pts
$BB mount -t tmpfs -o mode=1777 shm /newroot/dev/shm || fail "cannot mount /dev/shm"
$BB mount -t devpts -o ptmxmode=0666,mode=0620 devpts /newroot/dev/pts || fail "cannot mount devpts"
[ -e /newroot/dev/ptmx ] || $BB ln -s pts/ptmx /newroot/dev/ptmx

# A private tmpfs on /tmp (fast, no 9p), with the entries of the host's /tmp
# that the job needs (its working directory, the repo, ...) bound back in.
$BB mount -o bind /newroot/tmp /hosttmp || fail "cannot bind the host's /tmp"
$BB mount -t tmpfs -o mode=1777 tmp /newroot/tmp || fail "cannot mount tmpfs on /tmp"
case "$job" in
    /tmp/*) binds="/hosttmp${job#/tmp}/tmpbinds" ;;
    *) binds="/newroot$job/tmpbinds" ;;
esac
if [ -f "$binds" ]; then
    while IFS= read -r name; do
        [ -n "$name" ] && [ -e "/hosttmp/$name" ] || continue
        if [ -d "/hosttmp/$name" ]; then
            $BB mkdir -p "/newroot/tmp/$name"
        else
            : > "/newroot/tmp/$name"
        fi
        $BB mount -o bind "/hosttmp/$name" "/newroot/tmp/$name" || fail "cannot bind /tmp/$name"
    done < "$binds"
fi
stage mounts

$BB hostname aacmm-vcan
setup_out=$($BB env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin $BB chroot /newroot /bin/sh "$job/setup.sh" 2>&1) \
    || fail "network setup failed: $setup_out"
stage network

$BB stty -F /dev/ttyS1 raw -echo 2>/dev/null
$BB stty -F /dev/ttyS2 raw -echo 2>/dev/null
stage command
$BB env -i $BB chroot /newroot /bin/sh "$job/job.sh" </dev/null >/dev/ttyS1 2>/dev/ttyS2
rc=$?
stage done
finish "$rc"
