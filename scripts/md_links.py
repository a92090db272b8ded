#!/usr/bin/env python3
"""Relative links in the repository's Markdown files whose target file or `#anchor` does not exist.

Usage: scripts/md_links.py [FILE.md ...]   (default: every tracked *.md outside target/ and fuzz/)
Checks `[text](target)` links that are not URLs: the file must exist (relative to the linking file),
and a `#anchor` must be a heading of the target (GitHub's slugs: lower case, punctuation and symbols
dropped, spaces to hyphens, repeats numbered -1, -2, …). Links inside code spans and fenced code
blocks, and rustdoc intra-doc targets kept in moved module docs (`[`DosNet`](DosNet)`), are ignored.
Prints one line per broken link and exits 1 if there is any. A developer's check, not run by CI.
"""
import os
import re
import subprocess
import sys
import unicodedata

LINK = re.compile(r'(?<!!)\[(?:[^\[\]]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+"[^"]*")?\)')
FENCE = re.compile(r'^\s*(```|~~~)')


def strip_code(text):
    out, fenced = [], False
    for line in text.split('\n'):
        if FENCE.match(line):
            fenced = not fenced
            out.append('')
            continue
        # a code span's text is blanked (a link written in one is not a link); `[`x`](y)` stays a link
        out.append('' if fenced else re.sub(r'`[^`]*`', lambda m: '`' + ' ' * (len(m.group(0)) - 2) + '`', line))
    return out


def slug(heading):
    h = re.sub(r'\[([^\]]*)\]\([^)]*\)', r'\1', heading)  # [text](url) → text
    h = h.strip().lower()
    keep = []
    for ch in h:
        cat = unicodedata.category(ch)
        if ch in '-_' or cat[0] in 'LNM':
            keep.append(ch)
        elif ch == ' ':
            keep.append('-')
    return ''.join(keep)


def anchors(path, cache={}):
    if path not in cache:
        seen, found = {}, set()
        fenced = False
        with open(path, encoding='utf-8') as f:
            for line in f:
                if FENCE.match(line):
                    fenced = not fenced
                    continue
                m = None if fenced else re.match(r'^(#{1,6})\s+(.*?)\s*#*\s*$', line)
                if m:
                    s = slug(m.group(2))
                    n = seen.get(s, 0)
                    found.add(s if n == 0 else f'{s}-{n}')
                    seen[s] = n + 1
        cache[path] = found
    return cache[path]


def main(files):
    bad = 0
    for md in files:
        for no, line in enumerate(strip_code(open(md, encoding='utf-8').read()), 1):
            for m in LINK.finditer(line):
                target = m.group(1)
                if re.match(r'^[a-z][a-z0-9+.-]*:', target, re.I):
                    continue  # a URL (https:, mailto:, …)
                if re.fullmatch(r'[A-Za-z_][A-Za-z0-9_:]*', target):
                    continue  # a rustdoc intra-doc link kept in moved module docs (`[`DosNet`](DosNet)`)
                path, _, frag = target.partition('#')
                full = os.path.normpath(os.path.join(os.path.dirname(md), path)) if path else md
                if not os.path.exists(full):
                    print(f'{md}:{no}: {target}: no file {full}')
                    bad += 1
                elif frag and full.endswith('.md') and frag not in anchors(full):
                    print(f'{md}:{no}: {target}: no heading #{frag} in {full}')
                    bad += 1
    return 1 if bad else 0


if __name__ == '__main__':
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), '..'))
    tracked = subprocess.run(['git', 'ls-files', '*.md'], capture_output=True, text=True, check=True).stdout.split()
    args = sys.argv[1:] or [p for p in tracked if not p.startswith(('target/', 'fuzz/'))]
    sys.exit(main(args))
