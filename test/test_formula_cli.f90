!> Tests of model files through the `holosym` command, run as a user runs it: `simulate
!! --model` gives the rows of the built-in twin, `--set` changes a parameter, `ensemble
!! --model` and `tables --model` run a user's system, and bad models and option mixes are
!! refused with a message that says where.
module test_formula_cli
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str, real_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, split_field
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, &
        scratch_path, read_lines, any_line_contains, write_lines, words
    implicit none
    private
    public :: formula_cli_tests

    !> Built-in systems and their model twins.
    character(len=*), parameter :: builtins(*) = [character(len=10) :: "pendulum", "linkage", &
        "planar", "double", "dumbbell", "magnetic", "generic", "chain"]
    character(len=*), parameter :: twin_files(*) = [character(len=40) :: &
        "example/models/spherical_pendulum.hsm", "example/models/spring_linkage.hsm", &
        "example/models/planar_pendulum.hsm", "example/models/double_pendulum.hsm", &
        "example/models/sphere_dumbbell.hsm", "example/models/magnetic_sphere.hsm", &
        "example/models/generic_pendulum.hsm", "example/models/chain8.hsm"]
    !> Rows of a twin and its built-in agree to this (relative to 1 + |value|).
    real(wp), parameter :: agreement = max(1.0e-30_wp, 1.0e3_wp * epsilon(1.0_wp))
    !> The multipliers, which Newton's last correction leaves less exact (their
    !! sensitivity grows like 1/h), agree to this.
    real(wp), parameter :: multiplier_agreement = max(1.0e-28_wp, 1.0e5_wp * epsilon(1.0_wp))

contains

    !> The tests of this suite.
    function formula_cli_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("simulate_model_rows_as_builtin", simulate_twins), &
            new_test("simulate_set_parameter", simulate_set), &
            new_test("simulate_projection_note", simulate_note), &
            new_test("simulate_refuses_bad_models", simulate_refusals), &
            new_test("simulate_model_events_file", simulate_events), &
            new_test("ensemble_model_as_builtin", ensemble_twin), &
            new_test("tables_model", tables_model)]
    end function formula_cli_tests

    !> Largest difference between the numeric fields 2.. of two CSV outputs (header and
    !! rows must match in number), relative to 1 + |value|; huge when they do not match.
    function rows_distance(a, b, last, first) result(worst)
        type(text_line_t), intent(in) :: a(:), b(:)
        integer, intent(in) :: last            !! compare fields first..last
        integer, intent(in), optional :: first !! default 1
        real(wp) :: worst, x, y
        integer :: i, k, ia, ib, start
        worst = huge(1.0_wp)
        if (size(a) /= size(b) .or. size(a) < 2) return
        if (a(1)%text /= b(1)%text) return
        worst = 0
        start = 1
        if (present(first)) start = first
        do i = 2, size(a)
            do k = start, last
                call field_number(a(i)%text, k, x, ia)
                call field_number(b(i)%text, k, y, ib)
                if (ia /= 0 .or. ib /= 0) then
                    worst = huge(1.0_wp)
                    return
                end if
                worst = max(worst, abs(x - y) / (1 + abs(y)))
            end do
        end do
    end function rows_distance

    !> Run holosym with `line`; fail unless it ran.
    subroutine run(error, line, result)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=*), intent(in) :: line
        type(command_result_t), intent(out) :: result
        call run_holosym(line, result)
        call check(error, len(result%failure) == 0, result%failure)
    end subroutine run

    !> `simulate --model TWIN` writes the rows of `simulate --system NAME` (t, q, p, the
    !! multipliers and H to round-off; the same header).
    subroutine simulate_twins(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a, b
        character(len=*), parameter :: scheme = " --M 4 --h 1/8 --steps 12 --every 4"
        integer :: k, fields, n, m
        real(wp) :: d, dl
        do k = 1, size(builtins)
            call run(error, "simulate --model " // trim(twin_files(k)) // scheme, a)
            if (allocated(error)) return
            call run(error, "simulate --system " // trim(builtins(k)) // scheme, b)
            if (allocated(error)) return
            call check(error, a%exit_code == 0 .and. b%exit_code == 0, trim(twin_files(k)) // &
                ": exit " // int_str(a%exit_code) // " and " // int_str(b%exit_code))
            if (allocated(error)) return
            ! Fields t, q1..qn, p1..pn, lambda1..lambdam, H, then four diagnostics.
            fields = count_fields(a%out(1)%text)
            n = count_prefix(a%out(1)%text, ",q")
            m = fields - 6 - 2 * n
            d = max(rows_distance(a%out, b%out, 1 + 2 * n), &
                    rows_distance(a%out, b%out, fields - 4, fields - 4))
            dl = rows_distance(a%out, b%out, 1 + 2 * n + m, 2 + 2 * n)
            call check(error, d <= agreement .and. dl <= multiplier_agreement, &
                trim(twin_files(k)) // ": rows differ from --system " // trim(builtins(k)) // &
                " by " // real_str(d) // " (t, q, p, H) and " // real_str(dl) // " (lambda)")
            if (allocated(error)) return
            call check(error, any_line_contains(a%err, "holosym simulate: model " // &
                trim(twin_files(k)) // " (n = "), "start line names the model")
            if (allocated(error)) return
        end do
    end subroutine simulate_twins

    !> Field k of a CSV line as a number.
    subroutine field_number(line, k, x, ios)
        character(len=*), intent(in) :: line
        integer, intent(in) :: k
        real(wp), intent(out) :: x
        integer, intent(out) :: ios
        character(len=:), allocatable :: field
        field = split_field(line, k, ",")
        x = 0
        read (field, *, iostat=ios) x
    end subroutine field_number

    !> Number of occurrences of `prefix` in `line`.
    pure integer function count_prefix(line, prefix) result(count)
        character(len=*), intent(in) :: line, prefix
        integer :: k
        count = 0
        do k = 1, len(line) - len(prefix) + 1
            if (line(k:k + len(prefix) - 1) == prefix) count = count + 1
        end do
    end function count_prefix

    !> Number of comma-separated fields.
    pure integer function count_fields(line)
        character(len=*), intent(in) :: line
        integer :: k
        count_fields = 1
        do k = 1, len(line)
            if (line(k:k) == ",") count_fields = count_fields + 1
        end do
    end function count_fields

    !> --set m=2 makes the pendulum's H0 = |p0|^2/4 - 2 sin(z0).
    subroutine simulate_set(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        real(wp) :: energy, expected
        integer :: ios
        call run(error, "simulate --model example/models/spherical_pendulum.hsm --set m=2 " &
            // "--set=l=1 --steps 2", a)
        if (allocated(error)) return
        call check(error, a%exit_code == 0, "exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call field_number(a%out(2)%text, 9, energy, ios)
        expected = 0.36_wp / 4 - 2 * sin(sqrt(2.0_wp) / 2)
        call check(error, ios == 0 .and. abs(energy - expected) <= 8 * epsilon(1.0_wp), &
            "H0 with m = 2: " // real_str(energy) // ", expected " // real_str(expected))
    end subroutine simulate_set

    !> `simulate --model F --events E` writes the model's events to E: the planar pendulum
    !! released at 1 rad passes the vertical (x = 0) at K and 3K, K = K(sin(1/2)) to 40
    !! digits from mpmath's elliptic integral; with `stop` the run ends at the first.
    !! --events without --model, and a model without events, are refused.
    subroutine simulate_events(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp), parameter :: quarter = 1.674993916092613178175302844790253856807_wp
        !> The scheme's accuracy at (8, 7, 9), h = 1/16 (about 1e-31 in real128, round-off
        !! in real64).
        real(wp), parameter :: accuracy = max(1.0e-30_wp, 1.0e4_wp * epsilon(1.0_wp))
        character(len=*), parameter :: options = " --M 8 --N 7 --G 9 --h 1/16 --steps 96 " &
            // "--every 96 --output "
        type(command_result_t) :: a
        type(text_line_t), allocatable :: rows(:)
        character(len=:), allocatable :: file, events, trajectory
        real(wp) :: t
        integer :: ios, j, trial
        file = scratch_path("vertical.hsm")
        events = scratch_path("vertical_events.csv")
        trajectory = scratch_path("vertical_rows.csv")
        do trial = 1, 2
            call write_lines(file, [character(len=60) :: "coordinates x y", &
                "momenta px py", "hamiltonian (px^2 + py^2)/2 + y", &
                "constraint x^2 + y^2 - 1", "initial x = sin(1), y = -cos(1)", &
                "event vertical: x" // merge(" stop", "     ", trial == 2)])
            call run(error, "simulate --model " // file // options // trajectory // &
                " --events " // events, a)
            if (allocated(error)) return
            call read_lines(events, rows, ios)
            call check(error, a%exit_code == 0 .and. ios == 0 .and. &
                size(rows) == merge(3, 2, trial == 1), "exit " // int_str(a%exit_code) // &
                ", " // int_str(size(rows)) // " lines in the events file")
            if (allocated(error)) return
            call check(error, rows(1)%text == "event,name,direction,t,q1,q2,p1,p2,lambda1", &
                "header " // rows(1)%text)
            if (allocated(error)) return
            do j = 1, size(rows) - 1
                call check(error, index(rows(j + 1)%text, "1,vertical," // &
                    trim(merge("-1", "1 ", j == 1)) // ",") == 1, "row " // rows(j + 1)%text)
                if (allocated(error)) return
                call field_number(rows(j + 1)%text, 4, t, ios)
                call check(error, ios == 0 .and. abs(t - (2 * j - 1) * quarter) <= accuracy, &
                    "passage " // int_str(j) // " at " // real_str(t))
                if (allocated(error)) return
            end do
            call check(error, any_line_contains(a%err, "holosym simulate: " // &
                int_str(size(rows) - 1) // " events written to " // events) .and. &
                (trial == 1 .neqv. any_line_contains(a%err, "a terminal event ended")), &
                "the summary line on stderr")
            if (allocated(error)) return
        end do
        call run(error, "simulate --system planar --events " // events, a)
        if (allocated(error)) return
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, "option " // &
            "--events writes the events of a model file's event statements: give --model"), &
            "--events without --model: exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call run(error, "simulate --model example/models/planar_pendulum.hsm --steps 2 " // &
            "--events " // events, a)
        if (allocated(error)) return
        call check(error, a%exit_code == 1 .and. any_line_contains(a%err, "option " // &
            "--events: the model states no event"), "a model without events: exit " // &
            int_str(a%exit_code))
    end subroutine simulate_events

    !> A model whose start is off its constraint is projected, and the note says so.
    subroutine simulate_note(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        character(len=:), allocatable :: file
        file = scratch_path("off_manifold.hsm")
        call write_lines(file, [character(len=60) :: "coordinates x y", "momenta px py", &
            "hamiltonian (px^2 + py^2)/2 + y", "constraint x^2 + y^2 - 1", &
            "initial x = 0.6, y = -0.81, px = 1, py = 1"])
        call run(error, "simulate --model " // file // " --steps 2", a)
        if (allocated(error)) return
        call check(error, a%exit_code == 0 .and. any_line_contains(a%err, &
            "holosym simulate: note: the initial state is off the constraint manifold"), &
            "exit " // int_str(a%exit_code) // "; the note of the projection")
    end subroutine simulate_note

    !> Bad models fail with exit 1 and "invalid model: FILE:LINE:COLUMN: ..."; options that
    !! do not fit together are usage errors (exit 2).
    subroutine simulate_refusals(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        character(len=:), allocatable :: file
        file = scratch_path("bad.hsm")
        call write_lines(file, [character(len=60) :: "coordinates x y", "momenta px py", &
            "hamiltonian px^2 + z"])
        call run(error, "simulate --model " // file, a)
        if (allocated(error)) return
        call check(error, a%exit_code == 1 .and. any_line_contains(a%err, &
            "holosym simulate: error: invalid model: " // file // ":3:20: unknown name 'z'"), &
            "bad model: exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call expect_usage("simulate --model " // file // " --system pendulum", &
            "options --system and --model: give one or the other")
        call expect_usage("simulate --set m=2", "option --set sets a parameter of a model: " &
            // "it needs --model")
        call expect_usage("simulate --model x.hsm --set m", "option --set expects NAME=VALUE")
        call expect_usage("simulate --model x.hsm --set m=two", "option --set m expects a " // &
            "number")
        call expect_usage("simulate --model x.hsm --links 3", "option --links needs " // &
            "--system chain")
        call run(error, "simulate --model example/models/water.hsm --set zz=1 --steps 1", a)
        if (allocated(error)) return
        call check(error, a%exit_code == 1 .and. any_line_contains(a%err, &
            "option --set zz=1: the model has no parameter 'zz' (its parameters: mO, mH,"), &
            "unknown parameter: exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call run(error, "simulate --model build/no/such/model.hsm", a)
        if (allocated(error)) return
        call check(error, a%exit_code == 1 .and. any_line_contains(a%err, &
            "invalid model: build/no/such/model.hsm: "), "missing file: exit " // &
            int_str(a%exit_code))
    contains
        subroutine expect_usage(line, message)
            character(len=*), intent(in) :: line, message
            if (allocated(error)) return
            call run(error, line, a)
            if (allocated(error)) return
            call check(error, a%exit_code == 2 .and. any_line_contains(a%err, message), &
                line // ": exit " // int_str(a%exit_code) // ", expected 2 and '" // &
                message // "'")
        end subroutine expect_usage
    end subroutine simulate_refusals

    !> `ensemble --model` gives the results of `ensemble --system` for a twin.
    subroutine ensemble_twin(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a, b
        type(text_line_t), allocatable :: rows_a(:), rows_b(:)
        character(len=:), allocatable :: out_a, out_b
        integer :: ios, k, fields
        real(wp) :: d
        out_a = scratch_path("ensemble_model.csv")
        out_b = scratch_path("ensemble_builtin.csv")
        call run(error, "ensemble --model example/models/planar_pendulum.hsm --perturb 4 " // &
            "--T 1 --M 3 --quiet --output " // out_a, a)
        if (allocated(error)) return
        call run(error, "ensemble --system planar --perturb 4 --T 1 --M 3 --quiet " // &
            "--output " // out_b, b)
        if (allocated(error)) return
        call check(error, a%exit_code == 0 .and. b%exit_code == 0, "exit " // &
            int_str(a%exit_code) // " and " // int_str(b%exit_code))
        if (allocated(error)) return
        call read_lines(out_a, rows_a, ios)
        call read_lines(out_b, rows_b, ios)
        ! Skip the comment line naming the run; compare the states of the rows.
        call check(error, size(rows_a) == size(rows_b) .and. size(rows_a) >= 5, &
            "result rows: " // int_str(size(rows_a)) // " and " // int_str(size(rows_b)))
        if (allocated(error)) return
        k = 1
        do while (rows_a(k)%text(1:1) == "#")
            k = k + 1
        end do
        fields = 9
        d = rows_distance(rows_a(k:), rows_b(k:), 1)
        call check(error, d == 0, "ids differ")
        if (allocated(error)) return
        call check(error, index(rows_a(1)%text, "system=model example/models/" // &
            "planar_pendulum.hsm text=") > 0, "the results file names the model: " // &
            rows_a(1)%text)
        if (allocated(error)) return
        d = states_distance(rows_a(k + 1:), rows_b(k + 1:))
        call check(error, d <= agreement, "states differ by " // real_str(d))
    end subroutine ensemble_twin

    !> Largest difference of the numeric fields (those that read as numbers) of two sets
    !! of rows.
    function states_distance(a, b) result(worst)
        type(text_line_t), intent(in) :: a(:), b(:)
        real(wp) :: worst, x, y
        integer :: i, k, ia, ib
        worst = 0
        do i = 1, min(size(a), size(b))
            do k = 1, count_fields(a(i)%text)
                if (index(split_field(a(i)%text, k, ","), "E") == 0) cycle
                call field_number(a(i)%text, k, x, ia)
                call field_number(b(i)%text, k, y, ib)
                if (ia == 0 .and. ib == 0) worst = max(worst, abs(x - y) / (1 + abs(y)))
            end do
        end do
    end function states_distance

    !> `tables --model` measures the order of a user's system (order 2M with N = M - 1).
    subroutine tables_model(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        call run(error, "tables --model example/models/fourbar.hsm --Mmax 2 --Nmax 1 " // &
            "--T 2 --h 0.25,0.125", a)
        if (allocated(error)) return
        call check(error, a%exit_code == 0 .and. any_line_contains(a%out, &
            "### holosym tables: system model example/models/fourbar.hsm"), &
            "exit " // int_str(a%exit_code))
    end subroutine tables_model

end module test_formula_cli
