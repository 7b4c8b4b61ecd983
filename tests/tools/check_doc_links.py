#!/usr/bin/env python3
"""Checks every relative link in README.md, docs/**/*.md and the areas' README.md files: the file
exists, and a #fragment names a heading (GitHub's slugs) or an <a id> in the target. Prints each
broken link; exit 1 if any. Run after moving doc sections (e.g. into docs/notebook/):

    tests/tools/check_doc_links.py [REPO_ROOT]
"""
import os, re, sys, unicodedata

root = sys.argv[1] if len(sys.argv) > 1 else '.'

def slug(heading):
    h = heading.strip().lower()
    h = h.replace('`', '')
    h = re.sub(r'\[([^\]]*)\]\([^)]*\)', r'\1', h)
    out = []
    for ch in h:
        if ch in ' -':
            out.append('-')
        elif ch == '_' or unicodedata.category(ch)[0] in 'LN':
            out.append(ch)
    return ''.join(out)

def anchors(path):
    text = open(path, encoding='utf-8').read()
    text_nocode = re.sub(r'```.*?```', '', text, flags=re.S)
    seen = {}
    names = set(re.findall(r'<a id="([^"]+)"', text))
    for m in re.finditer(r'^#{1,6}\s+(.*?)\s*#*\s*$', text_nocode, flags=re.M):
        s = slug(m.group(1).replace('*', ''))
        n = seen.get(s, 0)
        names.add(s if n == 0 else f'{s}-{n}')
        seen[s] = n + 1
    return names

files = [os.path.join(root, 'README.md')]
for dp, dn, fn in os.walk(os.path.join(root, 'docs')):
    files += [os.path.join(dp, f) for f in fn if f.endswith('.md')]
# READMEs of the areas too
for top in ('common', 'server', 'client', 'proto', 'tests', 'deploy'):
    for dp, dn, fn in os.walk(os.path.join(root, top)):
        files += [os.path.join(dp, f) for f in fn if f == 'README.md']
bad = 0
cache = {}
for f in sorted(files):
    text = open(f, encoding='utf-8').read()
    text = re.sub(r'```.*?```', '', text, flags=re.S)
    text = re.sub(r'`[^`\n]*`', '', text)
    for m in re.finditer(r'\]\(([^)\s]+)\)', text):
        target = m.group(1)
        if re.match(r'[a-z]+:', target) or target.startswith('mailto'):
            continue
        path, _, frag = target.partition('#')
        dest = os.path.normpath(os.path.join(os.path.dirname(f), path)) if path else f
        if not os.path.exists(dest):
            print(f'{os.path.relpath(f, root)}: missing {target}'); bad += 1; continue
        if frag and dest.endswith('.md'):
            if dest not in cache: cache[dest] = anchors(dest)
            if frag not in cache[dest]:
                print(f'{os.path.relpath(f, root)}: no anchor {target}'); bad += 1
print(f'{len(files)} files checked, {bad} broken links')
sys.exit(1 if bad else 0)
