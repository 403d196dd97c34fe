#!/usr/bin/perl
# commands.pl -- lists the external commands a shell script runs, for
# tests/commands.sh.
#
#   perl tests/commands.pl FILE...   prints "FILE:LINE NAME" per use
#
# A small tokenizer of the POSIX shell (and the bash the scripts use), not
# a parser: it follows quotes ('...', "...", $'...'), command substitution
# ($(...), `...`), subshells, process substitution, ${...} and $((...)),
# here-documents (a body is data, but $(...) in one with an unquoted
# delimiter runs), comments, redirections
# (2>&1, >file: not commands), case patterns and [[ ... ]], and reports
# every literal word in command position: at the start of a command, after
# ; & | && || ! ( $( ` and the keywords that start a command (if then do
# ...), after assignments (X=1 cmd) and after the words that run their
# argument (nice, env, xargs, exec, timeout, sudo and $SUDO, command -v,
# whose argument is a command looked up). Not reported: builtins, keywords,
# the script's own functions, words with an expansion ($bin), paths into
# the tree (./run.sh, tests/x.sh). Strings handed to sh -c, awk and
# sqlite3 are data; the shebang's interpreter is a use.
use strict;
use warnings;

my %builtin = map { $_ => 1 } qw(
    : . [ alias bg break builtin caller cd command continue declare dirs disown echo enable eval
    exec exit export false fg getopts hash help history jobs kill let local logout mapfile popd
    printf pushd pwd read readarray readonly return set shift shopt source suspend test times trap
    true type typeset ulimit umask unalias unset wait);
my %starts = map { $_ => 1 } qw(if then else elif do while until ! { time);
my %ends = map { $_ => 1 } qw(fi done esac });
my %prefix = map { $_ => 1 } qw(nice env xargs exec timeout sudo nohup stdbuf setsid ionice command time);

my (%uses, %funcs);

# scan(FILE): the file; scan(FILE, TEXT, LINE): TEXT, found at LINE of FILE
sub scan {
    my ($file, $s, $line) = @_;
    if (!defined $s) {
        open my $fh, '<', $file or die "commands.pl: $file: $!\n";
        $s = do { local $/; <$fh> };
        close $fh;
        $line = 1;
    }
    my $n = length $s;
    my $i = 0;
    if ($line == 1 && $s =~ /\A#!\s*(\S+)(?:[ \t]+(\S+))?/) {
        my ($interp, $arg) = ($1, $2);
        (my $b = $interp) =~ s{.*/}{};
        $uses{"$file:1 $b"} = 1;
        $uses{"$file:1 $arg"} = 1 if $b eq 'env' && defined $arg;
    }
    # the state of one command context; pushed for $( ( `
    my %st = (cmd => 1, word => '', lit => 1, has => 0, redir => 0, pfx => 0, cmdv => 0,
              skip => 0, casehead => 0, pat => 0, dbr => 0, wline => 1);
    my @stack;          # saved states and their kinds
    my @ctx = ('top');  # top sub subst bq dq
    my @heredocs;       # delimiters waiting for the end of the line

    my $end_word = sub {
        return unless $st{has};
        my ($w, $lit) = ($st{word}, $st{lit});
        $st{word} = ''; $st{lit} = 1; $st{has} = 0;
        if ($st{redir}) { $st{redir} = 0; return; }
        $st{cmdv} = 0 if $w !~ /^-/;     # command -v "$x": not a literal name
        if ($st{pat}) {
            if ($w eq 'esac') { $st{pat} = 0; $st{cmd} = 0; }
            return;
        }
        if ($st{dbr}) { $st{dbr} = 0 if $w eq ']]'; $st{cmd} = 0 if $w eq ']]'; return; }
        if ($st{casehead}) {
            if ($w eq 'in') { $st{casehead} = 0; $st{pat} = 1; }
            return;
        }
        return if $st{skip};
        return unless $st{cmd};
        if ($st{pfx}) {
            # options and their numeric values, assignments (env), {} (xargs -I)
            return if $w =~ /^-/ || $w =~ /^[0-9.]+[smhd]?$/ || $w =~ /^[A-Za-z_][A-Za-z0-9_]*=/ || $w eq '{}';
            $st{pfx} = 0;
        }
        if ($w =~ /^[A-Za-z_][A-Za-z0-9_]*(\[[^]]*\])?\+?=/) { return; }      # assignment
        if (!$lit) {
            if ($w =~ /^"?\$\{?SUDO\}?"?$/) { $st{pfx} = 1; return; }
            $st{cmd} = 0; return;
        }
        if ($starts{$w}) { return; }
        if ($ends{$w}) { $st{cmd} = 0; return; }
        if ($w eq 'for' || $w eq 'select') { $st{skip} = 1; $st{cmd} = 0; return; }
        if ($w eq 'case') { $st{casehead} = 1; $st{cmd} = 0; return; }
        if ($w eq '[[') { $st{dbr} = 1; $st{cmd} = 0; return; }
        if ($w eq 'function') { $st{cmd} = 0; $st{fname} = 1; return; }
        my $name = $w;
        if ($name =~ m{/}) {
            if ($name =~ m{^/(usr/)?(local/)?s?bin/([^/]+)$}) { $name = $3; }
            else { $st{cmd} = 0; return; }
        }
        $uses{"$file:$st{wline} $name"} = 1 unless $builtin{$name};
        if ($name eq 'command') {
            $st{cmdv} = 1; $st{pfx} = 1; return;
        }
        if ($prefix{$name}) { $st{pfx} = 1; return; }
        $st{cmd} = 0;
    };
    my $sep = sub {     # ; & | && || newline: a new command starts
        $end_word->();
        $st{cmd} = 1; $st{pfx} = 0; $st{redir} = 0; $st{skip} = 0; $st{cmdv} = 0;
    };
    my $push = sub {    # a new command context: $( ( `
        my ($kind) = @_;
        push @stack, {%st};
        push @ctx, $kind;
        %st = (cmd => 1, word => '', lit => 1, has => 0, redir => 0, pfx => 0, cmdv => 0,
               skip => 0, casehead => 0, pat => 0, dbr => 0, wline => $line);
    };
    my $pop = sub {
        $end_word->();
        pop @ctx;
        %st = %{ pop @stack };
    };
    my $skip_balanced = sub {  # from an opening char at $i to its match
        my ($open, $close) = @_;
        my $depth = 0;
        for (; $i < $n; $i++) {
            my $c = substr($s, $i, 1);
            $line++ if $c eq "\n";
            if ($c eq '\\') { $i++; next; }
            if ($c eq "'" && $open eq '{') { my $j = index($s, "'", $i + 1); $j = $n - 1 if $j < 0; $line += () = substr($s, $i, $j - $i) =~ /\n/g; $i = $j; next; }
            $depth++ if $c eq $open;
            if ($c eq $close) { $depth--; return if $depth == 0; }
        }
    };
    my $word_char = sub {
        my ($c) = @_;
        $st{wline} = $line unless $st{has};
        $st{has} = 1; $st{word} .= $c;
    };

    while ($i < $n) {
        my $c = substr($s, $i, 1);
        my $c2 = substr($s, $i + 1, 1);
        my $kind = $ctx[-1];
        if ($kind eq 'dq') {
            if ($c eq '\\') { $word_char->($c2) unless $c2 eq "\n"; $line++ if $c2 eq "\n"; $i += 2; next; }
            if ($c eq '"') { pop @ctx; $i++; next; }
            if ($c eq '$' && $c2 eq '(' && substr($s, $i + 2, 1) eq '(') { $st{lit} = 0; $i++; $skip_balanced->('(', ')'); $i++; next; }
            if ($c eq '$' && $c2 eq '(') { $st{lit} = 0; my $save = $st{has}; $push->('subst'); $stack[-1]{has} = 1; $stack[-1]{lit} = 0; $i += 2; next; }
            if ($c eq '$' && $c2 eq '{') { $st{lit} = 0; $i++; $skip_balanced->('{', '}'); $i++; next; }
            if ($c eq '`') { $st{lit} = 0; $push->('bq'); $stack[-1]{has} = 1; $stack[-1]{lit} = 0; $i++; next; }
            $st{lit} = 0 if $c eq '$';
            $line++ if $c eq "\n";
            $word_char->($c);
            $i++;
            next;
        }
        # code: top sub subst bq
        if ($c eq "\n") {
            $line++;
            $sep->();
            $i++;
            while (@heredocs) {     # the bodies follow this line
                my ($delim, $tabs, $quoted) = @{ shift @heredocs };
                my ($body, $first) = ('', $line);
                while ($i < $n) {
                    my $j = index($s, "\n", $i);
                    $j = $n if $j < 0;
                    my $l = substr($s, $i, $j - $i);
                    $i = $j + 1;
                    $line++;
                    $l =~ s/^\t+// if $tabs;
                    last if $l eq $delim;
                    $body .= "$l\n";
                }
                # an unquoted delimiter: the body expands like a "..." string
                if (!$quoted && $body =~ /\$\(|`/) {
                    $body =~ s/(\\*)"/$1\\"/g;
                    scan($file, "\"$body\"", $first);
                }
            }
            next;
        }
        if ($c eq '\\') {
            if ($c2 eq "\n") { $end_word->(); $line++; }
            else { $word_char->($c2); }
            $i += 2; next;
        }
        if ($c eq ' ' || $c eq "\t") { $end_word->(); $i++; next; }
        if ($c eq '#' && !$st{has}) {
            my $j = index($s, "\n", $i);
            $i = $j < 0 ? $n : $j;
            next;
        }
        if ($c eq "'") {
            my $j = index($s, "'", $i + 1);
            $j = $n if $j < 0;
            my $t = substr($s, $i + 1, $j - $i - 1);
            $st{wline} = $line unless $st{has};
            $st{has} = 1; $st{word} .= $t;
            $line += () = $t =~ /\n/g;
            $i = $j + 1; next;
        }
        if ($c eq '"') {
            $st{wline} = $line unless $st{has};
            $st{has} = 1; push @ctx, 'dq'; $i++; next;
        }
        if ($c eq '$') {
            $st{wline} = $line unless $st{has};
            $st{has} = 1; $st{lit} = 0;
            if ($c2 eq '(' && substr($s, $i + 2, 1) eq '(') { $i++; $skip_balanced->('(', ')'); $i++; next; }
            if ($c2 eq '(') { $st{word} .= '$('; $push->('subst'); $i += 2; next; }
            if ($c2 eq '{') { $st{word} .= '${'; $i++; $skip_balanced->('{', '}'); $i++; next; }
            if ($c2 eq "'") { my $j = index($s, "'", $i + 2); $j = $n if $j < 0; $i = $j + 1; next; }
            $st{word} .= '$'; $i++; next;
        }
        if ($c eq '`') {
            if ($kind eq 'bq') { $pop->(); $i++; next; }
            $st{wline} = $line unless $st{has};
            $st{has} = 1; $st{lit} = 0;
            $push->('bq'); $i++; next;
        }
        if ($c eq ';') {
            if ($c2 eq ';' || $c2 eq '&') { $sep->(); $st{pat} = 1; $i += 2; next; }
            $sep->(); $i++; next;
        }
        if ($c eq '&' && $c2 eq '>') { $end_word->(); $st{redir} = 1; $i += 2; $i++ if substr($s, $i, 1) eq '>'; next; }
        if ($c eq '|' || $c eq '&') {
            if ($st{pat}) { $end_word->(); $i++; next; }
            if ($st{dbr}) { $end_word->(); $i += ($c2 eq $c) ? 2 : 1; next; }
            $sep->(); $i += ($c2 eq $c || ($c eq '|' && $c2 eq '&')) ? 2 : 1; next;
        }
        if ($c eq '<' || $c eq '>') {
            if (($c2 eq '(') && !$st{has}) { $push->('sub'); $i += 2; next; }   # <(cmd) >(cmd)
            $st{word} = '', $st{has} = 0 if $st{has} && $st{word} =~ /^[0-9]+$/ && $st{lit};   # 2>
            $end_word->();
            if ($c eq '<' && $c2 eq '<' && substr($s, $i + 2, 1) ne '<') {    # here-document
                $i += 2;
                my $tabs = 0;
                if (substr($s, $i, 1) eq '-') { $tabs = 1; $i++; }
                $i++ while substr($s, $i, 1) =~ /[ \t]/;
                my $d = '';
                while ($i < $n && substr($s, $i, 1) !~ /[\s;&|<>()]/) { $d .= substr($s, $i, 1); $i++; }
                my $quoted = $d =~ /['"\\]/;
                $d =~ s/['"\\]//g;
                push @heredocs, [$d, $tabs, $quoted];
                next;
            }
            $i++;
            $i++ while $i < $n && substr($s, $i, 1) =~ /[<>&|]/;
            $st{redir} = 1;
            next;
        }
        if ($c eq '(') {
            if ($st{has} && $c2 eq ')') {   # name() { ... }: a function
                $funcs{$st{word}} = 1 if $st{lit};
                $st{word} = ''; $st{has} = 0; $st{cmd} = 1;   # the body follows
                $i += 2; next;
            }
            if ($st{pat}) { $i++; next; }
            if ($st{has} && $st{word} =~ /^[A-Za-z_][A-Za-z0-9_]*\+?=$/) {   # x=(a b): an array
                $skip_balanced->('(', ')'); $st{word} .= '()'; $i++; next;
            }
            if ($st{cmd} && $c2 eq '(') { $skip_balanced->('(', ')'); $i++; $st{cmd} = 0; next; }   # (( ))
            $end_word->();
            $push->('sub'); $i++; next;
        }
        if ($c eq ')') {
            if ($st{pat}) { $end_word->(); $st{pat} = 0; $st{cmd} = 1; $i++; next; }
            if ($kind eq 'sub' || $kind eq 'subst') { $pop->(); $i++; $st{cmd} = 0 if $kind eq 'sub'; next; }
            $end_word->(); $st{cmd} = 1; $i++; next;
        }
        if ($st{fname} && !$st{has}) {     # function NAME
            my $j = $i;
            $j++ while $j < $n && substr($s, $j, 1) =~ /[A-Za-z0-9_.-]/;
            $funcs{substr($s, $i, $j - $i)} = 1;
            $st{fname} = 0; $i = $j; next;
        }
        if ($st{cmdv} && !$st{has} && $c ne '-') {
            # command -v NAME: NAME is looked up; report it, nothing runs
            $st{cmdv} = 0;
            my $j = $i;
            $j++ while $j < $n && substr($s, $j, 1) =~ /[A-Za-z0-9_.+-]/;
            my $w = substr($s, $i, $j - $i);
            if ($w ne '' && substr($s, $j, 1) =~ /[\s;&|)>]/) { $uses{"$file:$line $w"} = 1; $st{cmd} = 0; $st{pfx} = 0; $i = $j; next; }
        }
        $word_char->($c);
        $i++;
    }
    $end_word->();
}

scan($_) for @ARGV;
for my $u (sort keys %uses) {
    my ($where, $name) = split / /, $u, 2;
    next if $funcs{$name};
    print "$where $name\n";
}
