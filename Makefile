# armlab: every target creates .venv and installs requirements.txt + the package on first use.
PY      := .venv/bin/python
# A student release (make student) carries this marker: its `make test` runs the kit's tests, not the notebooks'
# checks, whose exercises are still blank there.
RELEASE := $(wildcard .student-release)
STAMP   := .venv/.installed
NBVAL   := --nbval --nbval-sanitize-with tests/nbval_sanitize.cfg --nbval-cell-timeout=600
# Test files run in parallel, one process per core (at most 4); the tests of one file, and the cells of one notebook
# (one kernel), stay together in one process (pytest-xdist's loadfile), the longest files first (conftest.py's
# START_FIRST, in place of xdist's order by number of tests, which handed the longest file out last). `make test`
# lists its 25 slowest steps at the end (a test's call, or a module fixture's setup), for keeping the suite in budget.
PAR     := -n auto --maxprocesses 4 --dist loadfile --no-loadscope-reorder
LINT_MORE :=
# BEGIN INSTRUCTOR ONLY (the student release leaves these lines out: armlab_course.exercises.release)
LINT_MORE := benchmarks tools/build-notebook tools/student-release tools/exercise-docs
# END INSTRUCTOR ONLY

.PHONY: demo test check lint unit lab browser camera sandbox docs clean

# The first install (80-106 s) says what it does: a line as each step starts and one with its time when it ends;
# the long step (requirements.txt) also shows pip's "Collecting" line per package and the count it installs.
# pip's warnings and errors (stderr) pass as they are. The one message kept out of sight is setuptools'
# informational "Editable installation" note (folders in the working directory named like the package may take
# precedence in imports): here that folder is the package the editable install points to.
define step
	@echo "armlab install [$(1)] $(2) ..."
	@t0=$$(date +%s); $(3) && echo "armlab install [$(1)] done in $$(( $$(date +%s) - t0 )) s"
endef
PIP_LINES := awk '/^Collecting / {print "    collecting " $$2; fflush()} /^Installing collected packages/ \
	{print "    installing " split($$0, names, ",") " packages ..."; fflush()}'

$(STAMP): requirements.txt pyproject.toml
	$(call step,1/4,a virtual environment in .venv,test -x $(PY) || python3 -m venv .venv)
	$(call step,2/4,the newest pip,$(PY) -m pip install --quiet --upgrade pip)
	$(call step,3/4,the kit's dependencies from requirements.txt (about 80 s the first time),\
		{ $(PY) -m pip install -r requirements.txt; echo $$? >.venv/.pip-status; } | $(PIP_LINES); \
		test "$$(cat .venv/.pip-status)" = 0)
	$(call step,4/4,the kit itself (editable: your changes to armlab/ count at once),\
		PYTHONWARNINGS="ignore:Editable installation" $(PY) -m pip install --quiet --no-deps -e .)
	@touch $(STAMP)

## make demo: the main job, headless, on the simulator
demo: $(STAMP)
	MPLBACKEND=Agg $(PY) -m armlab demo

## make test: lint + the kit's tests (installs headless Chromium for the browser checks); in the instructor's
## checkout also every notebook under nbval, natively and under other CPUs' numerics
test: $(STAMP) browser camera sandbox lint
ifeq ($(RELEASE),)
	$(PY) -m pytest -q $(PAR) --durations=25 tests notebooks $(NBVAL)
	bash tools/nbval-numerics $(PY) $(PAR) $(NBVAL)
else
	MPLBACKEND=Agg $(PY) -m pytest -q $(PAR) tests
endif

## make check: the public checks of the exercises written in this folder, in the grader's sandbox, a line per
## exercise as it goes (python -m armlab check; check one with: .venv/bin/python -m armlab check fk.euler)
check: $(STAMP) sandbox
	$(PY) -m armlab check

lint: $(STAMP)
	$(PY) -m ruff check armlab armlab_course tests notebooks tools/api-docs $(LINT_MORE)

unit: $(STAMP) camera sandbox
	MPLBACKEND=Agg $(PY) -m pytest -q $(PAR) tests

browser:
	bash tools/ensure-chromium

camera: $(STAMP)
	bash tools/ensure-realsense $(PY)

## the grader's sandbox (bubblewrap, prlimit, setpriv)
sandbox:
	bash tools/ensure-sandbox

## make lab: JupyterLab on notebooks/
lab: $(STAMP)
	$(PY) -m jupyter lab --notebook-dir=notebooks --allow-root --no-browser

## make docs: the API reference from the docstrings (pdoc) in docs/api/index.html
docs: $(STAMP)
	rm -rf docs/api
	$(PY) tools/api-docs docs/api

# BEGIN INSTRUCTOR ONLY (the student release leaves these lines out: armlab_course.exercises.release)
.PHONY: test-engine test-course
## make test-engine / make test-course: the library's tests alone (tests/, without tests/course/), or the course's
## (tests/course/: exercises, release, grader; minutes each for the grading files)
test-engine: $(STAMP) camera sandbox
	MPLBACKEND=Agg $(PY) -m pytest -q $(PAR) tests --ignore=tests/course

test-course: $(STAMP) camera sandbox
	MPLBACKEND=Agg $(PY) -m pytest -q $(PAR) tests/course

.PHONY: notebooks bench exercise-docs student autograder

notebooks: $(STAMP)
	$(PY) -m pytest -q $(PAR) notebooks $(NBVAL)
	bash tools/nbval-numerics $(PY) $(PAR) $(NBVAL)

## make bench: speed and accuracy tables
bench: $(STAMP)
	MPLBACKEND=Agg $(PY) benchmarks/run_all.py

## make exercise-docs: the docs' exercise counts, points and tables, generated from the registry
## (python -m armlab exercises --json; tools/exercise-docs --check only lists what is stale or contradicted)
exercise-docs: $(STAMP)
	$(PY) tools/exercise-docs

## make student: the student release (exercise regions stubbed, notebook outputs cleared) in dist/student
student: $(STAMP)
	rm -rf dist/student
	$(PY) tools/student-release dist/student

## make autograder: the Gradescope autograder bundle (setup.sh, run_autograder, the kit with its hidden checks) in
## dist/autograder and dist/autograder.zip, the file to upload
autograder: $(STAMP)
	rm -rf dist/autograder dist/autograder.zip
	$(PY) -m armlab_course.grading.autograder build dist/autograder

# END INSTRUCTOR ONLY

clean:
	rm -rf .venv out dist
