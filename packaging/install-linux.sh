#!/bin/sh
# Put MimuCap in this user's application menu, from the bundle folder this script is in
# (copied there as install.sh by `make bundle`): the desktop entry goes to
# $XDG_DATA_HOME/applications (default ~/.local/share/applications), the icon to
# $XDG_DATA_HOME/icons/hicolor. The entry starts the bundle where it is: move the folder first,
# then run this. `./install.sh --uninstall` removes both again.
set -eu

here=$(cd "$(dirname "$0")" && pwd)
data=${XDG_DATA_HOME:-$HOME/.local/share}
entry="$data/applications/mimucap.desktop"
svg="$data/icons/hicolor/scalable/apps/mimucap.svg"
png="$data/icons/hicolor/256x256/apps/mimucap.png"

refresh() {
    # Menus and icon caches notice the change sooner; neither tool is needed.
    command -v update-desktop-database >/dev/null 2>&1 && update-desktop-database -q "$data/applications" || true
    command -v gtk-update-icon-cache >/dev/null 2>&1 && gtk-update-icon-cache -q -t "$data/icons/hicolor" || true
}

if [ "${1:-}" = "--uninstall" ]; then
    rm -f "$entry" "$svg" "$png"
    refresh
    echo "MimuCap removed from the application menu"
    exit 0
fi
if [ $# -gt 0 ]; then
    echo "usage: $0 [--uninstall]" >&2
    exit 2
fi

program="$here/mimucap"
resources="$here/_internal/mimucap/_resources/icons"
if [ ! -x "$program" ] || [ ! -f "$here/_internal/mimucap.desktop" ]; then
    echo "$0: run the install.sh inside the MimuCap bundle folder (beside the mimucap program)" >&2
    exit 1
fi
case "$program" in
    *'"'* | *'\'* | *'`'* | *'$'* | *'|'* | *'&'*)
        echo "$0: the folder's path ($here) has a character a desktop entry cannot quote; move it" >&2
        exit 1 ;;
esac

mkdir -p "$(dirname "$entry")" "$(dirname "$svg")" "$(dirname "$png")"
# The entry names the program by its full path (quoted: the path may hold spaces).
sed -e "s|^Exec=mimucap |Exec=\"$program\" |" -e "s|^TryExec=.*|TryExec=$program|" \
    "$here/_internal/mimucap.desktop" > "$entry.tmp"
mv "$entry.tmp" "$entry"
cp "$resources/mimucap.svg" "$svg"
cp "$resources/mimucap.png" "$png"
refresh
echo "MimuCap is in the application menu ($entry)"
