# The report's fragment template (grader.render.html) as jinja2 3.1.6 compiles it: written by
# `python -m grader.render.html`, never by hand (grader.render.precompiled).
JINJA2 = "3.1.6"
DIGEST = "e261c355f48de10a6c4bca6273cd0576f5a02d370663ed11f1b590b364c1f44a"
from jinja2.runtime import LoopContext, Macro, Markup, Namespace, TemplateNotFound, TemplateReference, TemplateRuntimeError, Undefined, escape, identity, internalcode, markup_join, missing, str_join
name = 'fragment'

def root(context, missing=missing):
    resolve = context.resolve_or_missing
    undefined = environment.undefined
    concat = environment.concat
    cond_expr_undefined = Undefined
    if 0: yield None
    l_0_style = resolve('style')
    l_0_root = resolve('root')
    l_0_kind = resolve('kind')
    l_0_pid = resolve('pid')
    l_0_h = resolve('h')
    l_0_report = resolve('report')
    l_0_seed = resolve('seed')
    l_0_footer = resolve('footer')
    l_0_landmark = resolve('landmark')
    l_0_num = resolve('num')
    l_0_adjustments = resolve('adjustments')
    l_0_verdict = resolve('verdict')
    pass
    yield '<style>'
    yield escape((undefined(name='style') if l_0_style is missing else l_0_style))
    yield '</style>\n<'
    yield escape((undefined(name='root') if l_0_root is missing else l_0_root))
    yield ' class="jl-report '
    yield escape((undefined(name='kind') if l_0_kind is missing else l_0_kind))
    yield '" id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'report" lang="en">\n<h'
    yield escape((undefined(name='h') if l_0_h is missing else l_0_h))
    yield ' class="title" id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'title">Jacobians &amp; Linearization: grading report</h'
    yield escape((undefined(name='h') if l_0_h is missing else l_0_h))
    yield '>\n<p class="note">Submission '
    yield escape(environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'submission'))
    yield ' &middot; seed '
    yield escape((undefined(name='seed') if l_0_seed is missing else l_0_seed))
    if environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'learner'):
        pass
        yield ' &middot; quiz learner '
        yield escape(environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'learner'))
    yield '</p>\n<p class="note" id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'provenance">'
    yield escape((undefined(name='footer') if l_0_footer is missing else l_0_footer))
    yield '</p>\n<section id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'summary"'
    yield escape(context.call((undefined(name='landmark') if l_0_landmark is missing else l_0_landmark), 'summary'))
    yield '><h'
    yield escape(((undefined(name='h') if l_0_h is missing else l_0_h) + 1))
    yield ' class="summary-title" id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'summary-title">Summary</h'
    yield escape(((undefined(name='h') if l_0_h is missing else l_0_h) + 1))
    yield '>\n<table class="summary"><caption>Points by chapter</caption>\n<thead><tr><th scope="col">chapter</th><th scope="col">title</th><th scope="col" class="num">code</th><th scope="col" class="num">quiz</th><th scope="col" class="num">total</th></tr></thead>\n<tbody>'
    for l_1_ch in environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'chapters'):
        _loop_vars = {}
        pass
        yield '<tr><th scope="row"><a href="#'
        yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '">'
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '</a></th><td>'
        yield escape(environment.getattr(l_1_ch, 'title'))
        yield '</td>\n<td class="num" data-code="'
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '">'
        yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), context.call(environment.getattr(l_1_ch, 'score_of'), 'code', _loop_vars=_loop_vars), _loop_vars=_loop_vars))
        yield ' / '
        yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), context.call(environment.getattr(l_1_ch, 'max_score_of'), 'code', _loop_vars=_loop_vars), _loop_vars=_loop_vars))
        yield '</td>\n<td class="num" data-quiz="'
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '">'
        yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), context.call(environment.getattr(l_1_ch, 'score_of'), 'quiz', _loop_vars=_loop_vars), _loop_vars=_loop_vars))
        yield ' / '
        yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), context.call(environment.getattr(l_1_ch, 'max_score_of'), 'quiz', _loop_vars=_loop_vars), _loop_vars=_loop_vars))
        yield '</td>\n<td class="num" data-total="'
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '">'
        yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), environment.getattr(l_1_ch, 'score'), _loop_vars=_loop_vars))
        yield ' / '
        yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), environment.getattr(l_1_ch, 'max_score'), _loop_vars=_loop_vars))
        yield '</td></tr>'
    l_1_ch = missing
    yield '</tbody>\n<tfoot><tr><th scope="row" colspan="4">Total</th><td class="num" id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'total">'
    yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'score')))
    yield ' / '
    yield escape(context.call((undefined(name='num') if l_0_num is missing else l_0_num), environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'max_score')))
    yield '</td></tr></tfoot></table>\n'
    if (undefined(name='adjustments') if l_0_adjustments is missing else l_0_adjustments):
        pass
        yield '<ul id="'
        yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
        yield 'adjustments">'
        for l_1_a in (undefined(name='adjustments') if l_0_adjustments is missing else l_0_adjustments):
            _loop_vars = {}
            pass
            yield '<li>'
            yield escape(('late penalty' if (environment.getattr(l_1_a, 'kind') == 'late') else 'override'))
            yield ': '
            yield escape(context.call(environment.getattr(l_1_a, 'describe'), _loop_vars=_loop_vars))
            yield '</li>'
        l_1_a = missing
        yield '</ul>'
    yield '\n<p id="'
    yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
    yield 'verdict">'
    yield escape((undefined(name='verdict') if l_0_verdict is missing else l_0_verdict))
    yield '</p>\n</section>\n'
    for l_1_ch in environment.getattr((undefined(name='report') if l_0_report is missing else l_0_report), 'chapters'):
        l_1_plural = resolve('plural')
        l_1_figures = resolve('figures')
        l_1_checks_html = resolve('checks_html')
        _loop_vars = {}
        pass
        yield '\n<section class="chapter" id="'
        yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '"'
        yield escape(context.call((undefined(name='landmark') if l_0_landmark is missing else l_0_landmark), environment.getattr(l_1_ch, 'chapter'), _loop_vars=_loop_vars))
        yield '><h'
        yield escape(((undefined(name='h') if l_0_h is missing else l_0_h) + 1))
        yield ' class="chapter-title" id="'
        yield escape((undefined(name='pid') if l_0_pid is missing else l_0_pid))
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield '-title">'
        yield escape(environment.getattr(l_1_ch, 'chapter'))
        yield ' &middot; '
        yield escape(environment.getattr(l_1_ch, 'title'))
        yield '</h'
        yield escape(((undefined(name='h') if l_0_h is missing else l_0_h) + 1))
        yield '>\n'
        if ((environment.getattr(l_1_ch, 'source') and (not environment.getattr(l_1_ch, 'unread'))) and (context.call(environment.getattr(environment.getattr(l_1_ch, 'source'), 'endswith'), '.ipynb', _loop_vars=_loop_vars) or context.call(environment.getattr(environment.getattr(l_1_ch, 'source'), 'startswith'), 'the code', _loop_vars=_loop_vars))):
            pass
            yield '<p class="note">graded: '
            yield escape(environment.getattr(l_1_ch, 'source'))
            yield '</p>'
        yield '\n'
        for l_2_note in environment.getattr(l_1_ch, 'notes'):
            _loop_vars = {}
            pass
            yield '<p class="note">note: '
            yield escape(l_2_note)
            yield '</p>'
        l_2_note = missing
        yield '\n'
        for l_2_problem in environment.getattr(l_1_ch, 'problems'):
            _loop_vars = {}
            pass
            yield '<pre class="problem">'
            yield escape(l_2_problem)
            yield '</pre>'
        l_2_problem = missing
        yield '\n'
        if environment.getattr(l_1_ch, 'hidden_checks'):
            pass
            yield '<p class="note">'
            yield escape(context.call((undefined(name='plural') if l_1_plural is missing else l_1_plural), environment.getattr(l_1_ch, 'hidden_checks'), 'hidden check', _loop_vars=_loop_vars))
            yield ' ('
            yield escape(context.call((undefined(name='plural') if l_1_plural is missing else l_1_plural), environment.getattr(l_1_ch, 'hidden_points'), 'point', _loop_vars=_loop_vars))
            yield ') run'
            yield escape(('s' if (environment.getattr(l_1_ch, 'hidden_checks') == 1) else cond_expr_undefined("the inline if-expression on line 22 in 'fragment' evaluated to false and no else section was defined.")))
            yield ' when you submit.</p>'
        yield '\n'
        for l_2_fig in environment.getitem((undefined(name='figures') if l_1_figures is missing else l_1_figures), environment.getattr(l_1_ch, 'chapter')):
            _loop_vars = {}
            pass
            yield '<figure>'
            if environment.getattr(l_2_fig, 'uri'):
                pass
                yield '<img src="'
                yield escape(environment.getattr(l_2_fig, 'uri'))
                yield '" alt="'
                yield escape(environment.getattr(l_2_fig, 'alt'))
                yield '" width="'
                yield escape(environment.getattr(l_2_fig, 'width'))
                yield '" height="'
                yield escape(environment.getattr(l_2_fig, 'height'))
                yield '">'
            yield '\n<figcaption>'
            yield escape(environment.getattr(l_2_fig, 'caption'))
            if environment.getattr(l_2_fig, 'gave'):
                pass
                yield '<span class="gave">'
                yield escape(environment.getattr(l_2_fig, 'gave'))
                yield '</span>'
            yield '</figcaption></figure>'
        l_2_fig = missing
        yield '\n'
        yield escape(context.call((undefined(name='checks_html') if l_1_checks_html is missing else l_1_checks_html), l_1_ch, (undefined(name='h') if l_0_h is missing else l_0_h), _loop_vars=_loop_vars))
        yield '\n</section>'
    l_1_ch = l_1_plural = l_1_figures = l_1_checks_html = missing
    yield '\n</'
    yield escape((undefined(name='root') if l_0_root is missing else l_0_root))
    yield '>'

blocks = {}
debug_info = '1=24&2=26&3=32&4=38&5=46&6=50&9=60&10=71&11=77&12=83&13=91&14=97&15=113&17=117&18=124&19=140&20=146&21=154&22=162&23=172&24=188&25=197&27=201'
