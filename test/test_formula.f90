!> Tests of systems given by formulas (model files): the grammar, the derivatives and the
!! structure holosym derives (against the hand-written built-in models and against
!! differences), the compiled forms in both precisions, parameters by name, initial
!! states, and the model twins of the built-in systems integrated side by side with them.
module test_formula
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, dp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, is_finite, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_MODEL, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_info_t
    use holosym_formula_model, only: formula_model, load_model, model_from_text
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_model_dumbbell, only: sphere_dumbbell
    use holosym_model_magnetic, only: magnetic_sphere
    use holosym_model_generic, only: generic_pendulum
    use holosym_test_systems, only: builtin_system
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code, &
        split_field, overflow_traps
    use holosym_test_commands, only: command_result_t, run_shell, scratch_path, text_line_t, &
        read_lines
    use holosym_manifold, only: manifold_residuals
    implicit none
    private
    public :: formula_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> The model twins of the built-in systems.
    character(len=*), parameter :: twins(*) = [character(len=24) :: "spherical_pendulum", &
        "spring_linkage", "planar_pendulum", "double_pendulum", "sphere_dumbbell", &
        "magnetic_sphere", "generic_pendulum"]
    !> The built-in systems they stand for (holosym_test_systems' names).
    character(len=*), parameter :: builtin_names(*) = [character(len=10) :: "pendulum", &
        "linkage", "planar", "double", "dumbbell", "magnetic", "generic"]
    character(len=*), parameter :: model_dir = "example/models/"
    !> Every model file of example/models.
    character(len=*), parameter :: examples(*) = [character(len=24) :: twins, "water", &
        "fourbar", "chain8"]

contains

    !> The tests of this suite.
    function formula_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("twins_match_builtin_bindings", twins_match_bindings), &
            new_test("twins_match_builtin_structure", twins_match_structure), &
            new_test("twins_integrate_as_the_builtins", twins_integrate), &
            new_test("example_models_load_and_step", example_models), &
            new_test("grammar_precedence_and_literals", grammar_values), &
            new_test("grammar_layout_continuations_comments", grammar_layout), &
            new_test("derivatives_of_every_function", every_function), &
            new_test("real64_tapes_agree", real64_tapes), &
            new_test("tapes_at_many_points_agree_with_one_point", tapes_at_points), &
            new_test("structure_found_or_not", structure_cases), &
            new_test("parameters_by_name", parameters_by_name), &
            new_test("initial_states_projected_or_refused", initial_states), &
            new_test("every_error_has_a_position", error_messages), &
            new_test("large_chain_as_the_builtin", large_chain), &
            new_test("water_and_fourbar_match_40_digit_references", independent_references), &
            new_test("fuzz_mutated_models_load_or_are_refused", fuzz_models)]
    end function formula_tests

    !> The built-in system a twin stands for, with its initial state.
    subroutine builtin(name, sys, q, p)
        character(len=*), intent(in) :: name !! the twin's file name
        class(constrained_hamiltonian), allocatable, intent(out) :: sys
        real(wp), allocatable, intent(out) :: q(:), p(:)
        integer :: k
        k = findloc(twins, name, 1)
        call builtin_system(trim(builtin_names(k)), sys, q, p)
    end subroutine builtin

    !> Load example/models/NAME.hsm.
    subroutine twin(name, model, error)
        character(len=*), intent(in) :: name
        type(formula_model), intent(out) :: model
        type(test_error_t), allocatable, intent(inout) :: error
        type(holosym_status_t) :: status
        call load_model(model_dir // trim(name) // ".hsm", model, status)
        call check(error, status%ok(), trim(name) // ": " // status%message)
    end subroutine twin

    !> Largest relative difference of two arrays (scaled by 1 + their magnitude).
    pure real(wp) function distance(a, b)
        real(wp), intent(in) :: a(:), b(:)
        distance = 0
        if (size(a) > 0) distance = maxval(abs(a - b)) / (1 + maxval(abs(b)))
    end function distance

    !> Every binding of each twin equals the built-in's at the start and at a nearby point.
    subroutine twins_match_bindings(error)
        type(test_error_t), allocatable, intent(out) :: error
        class(constrained_hamiltonian), allocatable :: sys
        type(formula_model) :: model
        real(wp), allocatable :: q(:), p(:), q0(:), p0(:), a(:), b(:), ja(:, :), jb(:, :)
        real(wp), allocatable :: h1(:, :), h2(:, :), h3(:, :), k1(:, :), k2(:, :), k3(:, :)
        real(wp), allocatable :: ca(:, :, :), cb(:, :, :)
        real(dp), allocatable :: ad(:), bd(:)
        integer :: t, trial, n, m
        real(wp) :: worst
        character(len=:), allocatable :: what
        do t = 1, size(twins)
            call builtin(trim(twins(t)), sys, q0, p0)
            call twin(twins(t), model, error)
            if (allocated(error)) return
            n = sys%n
            m = sys%m
            call check(error, model%n == n .and. model%m == m, trim(twins(t)) // ": sizes")
            if (allocated(error)) return
            allocate (q(n), p(n), a(n), b(n), ja(m, n), jb(m, n), h1(n, n), h2(n, n), &
                      h3(n, n), k1(n, n), k2(n, n), k3(n, n), ca(n, n, m), cb(n, n, m), &
                      ad(n), bd(n))
            do trial = 0, 1
                q = q0 + trial * 0.01_wp * [(sin(real(3 * t + n, wp)), n = 1, size(q0))]
                p = p0 + trial * 0.02_wp * [(cos(real(5 * t + n, wp)), n = 1, size(p0))]
                n = size(q)
                worst = abs(model%hamiltonian(q, p) - sys%hamiltonian(q, p)) / &
                    (1 + abs(sys%hamiltonian(q, p)))
                what = "H"
                call model%dh_dq(q, p, a)
                call sys%dh_dq(q, p, b)
                call note(distance(a, b), "dH/dq")
                call model%dh_dp(q, p, a)
                call sys%dh_dp(q, p, b)
                call note(distance(a, b), "dH/dp")
                call model%dh_dq_double(real(q, dp), real(p, dp), ad)
                call sys%dh_dq_double(real(q, dp), real(p, dp), bd)
                call note(real(maxval(abs(ad - bd)) / (1 + maxval(abs(bd))), wp) * &
                          (eps / epsilon(1.0_dp)), "dH/dq in real64")
                if (m > 0) then
                    call model%constraint(q, a(:m))
                    call sys%constraint(q, b(:m))
                    call note(distance(a(:m), b(:m)), "phi")
                    call model%constraint_jacobian(q, ja)
                    call sys%constraint_jacobian(q, jb)
                    call note(distance(reshape(ja, [m * n]), reshape(jb, [m * n])), "Phi")
                    call model%constraint_hessian(q, ca)
                    call sys%constraint_hessian(q, cb)
                    call note(distance(reshape(ca, [n * n * m]), reshape(cb, [n * n * m])), &
                              "phi''")
                end if
                call model%hessian(q, p, h1, h2, h3)
                call sys%hessian(q, p, k1, k2, k3)
                call note(distance(reshape(h1, [n * n]), reshape(k1, [n * n])), "H_qq")
                call note(distance(reshape(h2, [n * n]), reshape(k2, [n * n])), "H_qp")
                call note(distance(reshape(h3, [n * n]), reshape(k3, [n * n])), "H_pp")
                call check(error, worst <= 64 * eps, trim(twins(t)) // ": " // what // &
                    " differs from the built-in's by " // real_str(worst))
                if (allocated(error)) return
            end do
            deallocate (q, p, a, b, ja, jb, h1, h2, h3, k1, k2, k3, ca, cb, ad, bd)
        end do
    contains
        subroutine note(d, name)
            real(wp), intent(in) :: d
            character(len=*), intent(in) :: name
            if (d > worst) then
                worst = d
                what = name
            end if
        end subroutine note
    end subroutine twins_match_bindings

    !> Each twin derives the structure its built-in declares: the masses where H is
    !! separable (none for the magnetic sphere), and Phi's pattern covers its nonzeros.
    subroutine twins_match_structure(error)
        type(test_error_t), allocatable, intent(out) :: error
        class(constrained_hamiltonian), allocatable :: sys
        type(formula_model) :: model
        real(wp), allocatable :: q0(:), p0(:), mass_a(:), mass_b(:), jb(:, :)
        integer, allocatable :: rows(:), cols(:)
        logical :: declared_a, declared_b
        logical, allocatable :: covered(:, :)
        integer :: t, e
        do t = 1, size(twins)
            call builtin(trim(twins(t)), sys, q0, p0)
            call twin(twins(t), model, error)
            if (allocated(error)) return
            allocate (mass_a(sys%n), mass_b(sys%n), jb(sys%m, sys%n), &
                      covered(sys%m, sys%n))
            declared_a = model%diagonal_mass(mass_a)
            declared_b = sys%diagonal_mass(mass_b)
            call check(error, declared_a .eqv. declared_b, trim(twins(t)) // &
                ": the separable form is " // trim(merge("found    ", "not found", &
                declared_a)) // " but the built-in " // trim(merge("declares it        ", &
                "does not declare it", declared_b)))
            if (allocated(error)) return
            if (declared_a) call check(error, all(mass_a == mass_b), trim(twins(t)) // &
                ": masses differ")
            if (allocated(error)) return
            call model%constraint_sparsity(rows, cols)
            ! A generic point: no entry of Phi vanishes by accident.
            call sys%constraint_jacobian(q0 + 0.01_wp * [(sin(real(7 * e, wp)), &
                                         e = 1, sys%n)], jb)
            covered = .false.
            do e = 1, size(rows)
                covered(rows(e), cols(e)) = .true.
            end do
            call check(error, all(covered .or. jb == 0), trim(twins(t)) // &
                ": Phi's derived pattern misses a nonzero")
            if (allocated(error)) return
            call check(error, count(covered) == count(jb /= 0), trim(twins(t)) // &
                ": Phi's derived pattern has " // int_str(count(covered)) // " entries, " // &
                int_str(count(jb /= 0)) // " nonzero at a generic point")
            if (allocated(error)) return
            deallocate (mass_a, mass_b, jb, covered)
        end do
    end subroutine twins_match_structure

    !> From the same start, each twin and its built-in give the same states to round-off
    !! after 20 steps of (4, 3, 5), h = 1/8 (the same path: reduced or general).
    subroutine twins_integrate(error)
        type(test_error_t), allocatable, intent(out) :: error
        class(constrained_hamiltonian), allocatable :: sys
        type(formula_model) :: model
        type(constrained_integrator) :: ia, ib
        type(holosym_status_t) :: status
        real(wp), allocatable :: q0(:), p0(:), qa(:), pa(:), qb(:), pb(:)
        integer :: t, done
        do t = 1, size(twins)
            call builtin(trim(twins(t)), sys, q0, p0)
            call twin(twins(t), model, error)
            if (allocated(error)) return
            call ia%init(model, 4, 3, 5, status)
            call check(error, status%ok(), trim(twins(t)) // ": " // status%message)
            if (allocated(error)) return
            call ib%init(sys, 4, 3, 5, status)
            qa = q0
            pa = p0
            qb = q0
            pb = p0
            call ia%integrate(model, qa, pa, 0.125_wp, 20, steps_done=done, status=status)
            call check(error, status%ok(), trim(twins(t)) // ": " // status%message)
            if (allocated(error)) return
            call ib%integrate(sys, qb, pb, 0.125_wp, 20, steps_done=done, status=status)
            call check(error, distance([qa, pa], [qb, pb]) <= max(1.0e-30_wp, 1.0e3_wp * eps), &
                trim(twins(t)) // ": the twin ends " // real_str(distance([qa, pa], [qb, pb])) &
                // " from the built-in")
            if (allocated(error)) return
        end do
    end subroutine twins_integrate

    !> Text from lines (trailing blanks trimmed), joined by line feeds.
    pure function text(lines)
        character(len=*), intent(in) :: lines(:)
        character(len=:), allocatable :: text
        integer :: k
        text = ""
        do k = 1, size(lines)
            text = text // trim(lines(k)) // new_line("a")
        end do
    end function text

    !> A model from text, which must load.
    subroutine loaded(source, model, error)
        character(len=*), intent(in) :: source
        type(formula_model), intent(out) :: model
        type(test_error_t), allocatable, intent(inout) :: error
        type(holosym_status_t) :: status
        call model_from_text(source, model, status)
        call check(error, status%ok(), "model refused: " // status%message)
    end subroutine loaded

    !> Every example model loads, states a start on its manifold and takes ten steps of
    !! (4, 3, 5), h = 1/16, with phi at round-off.
    subroutine example_models(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        type(step_info_t) :: info
        real(wp), allocatable :: q(:), p(:)
        character(len=:), allocatable :: note
        integer :: t, k
        do t = 1, size(examples)
            call twin(examples(t), model, error)
            if (allocated(error)) return
            allocate (q(model%n), p(model%n))
            call model%initial_state(q, p, status, note)
            call check(error, status%ok(), trim(examples(t)) // ": " // status%message)
            if (allocated(error)) return
            call integ%init(model, 4, 3, 5, status)
            call check(error, status%ok(), trim(examples(t)) // ": " // status%message)
            if (allocated(error)) return
            do k = 1, 10
                call integ%step(model, q, p, 0.0625_wp, info, status)
                call check(error, status%ok(), trim(examples(t)) // ": " // status%message)
                if (allocated(error)) return
                call check(error, info%constraint_residual <= 1.0e3_wp * eps, &
                    trim(examples(t)) // ": |phi| = " // real_str(info%constraint_residual))
                if (allocated(error)) return
            end do
            deallocate (q, p)
        end do
    end subroutine example_models

    !> Precedence, associativity, unary signs, ** for ^, pi, atan with two arguments, and
    !! literals read as decimals in working precision.
    subroutine grammar_values(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=40), parameter :: cases(*) = [character(len=40) :: &
            "-x^2", "2^3^2", "2*3 + 4/2", "(1 + 2)*3", "x**2 - -x", "+x - -(-x)", &
            "2^-1", "-2^2", "1/2/2", "2 - 3 - 4", "0.1", "pi", "atan(1, -1)", "1.5e-3*x", &
            "sqrt(x^2)/x", "exp(log(x))"]
        real(wp) :: expected(size(cases)), x
        type(formula_model) :: model
        real(wp) :: q(2), p(2), value
        integer :: k
        x = 3
        expected = [-9.0_wp, 512.0_wp, 8.0_wp, 9.0_wp, 12.0_wp, 3.0_wp - 3.0_wp, 0.5_wp, &
                    -4.0_wp, 0.25_wp, -5.0_wp, 0.1_wp, 4 * atan(1.0_wp), atan2(1.0_wp, -1.0_wp), &
                    1.5e-3_wp * 3, 1.0_wp, 3.0_wp]
        do k = 1, size(cases)
            call loaded(text([character(len=80) :: "coordinates x y", "momenta px py", &
                "hamiltonian " // trim(cases(k)) // " + 0*(px + py + y)"]), model, error)
            if (allocated(error)) return
            q = [x, 0.0_wp]
            p = 0
            value = model%hamiltonian(q, p)
            call check(error, abs(value - expected(k)) <= 4 * eps * abs(expected(k)), &
                "'" // trim(cases(k)) // "' at x = 3 gives " // real_str(value) // &
                ", expected " // real_str(expected(k)))
            if (allocated(error)) return
        end do
        ! The literal is the working-precision number nearest to 1/10 (exactly 0.1_wp).
        call loaded(text([character(len=80) :: "coordinates x y", "momenta px py", &
            "hamiltonian 0.1 + 0*(x + y + px + py)"]), model, error)
        if (allocated(error)) return
        call check(error, model%hamiltonian(q, p) == 0.1_wp, "0.1 is not read in working " // &
            "precision")
    end subroutine grammar_values

    !> Comments, continuation lines (with comments after the '\'), blank lines, tabs,
    !! carriage returns, names separated by commas or spaces, several lets on a line,
    !! statements in any order that defines names before use.
    subroutine grammar_layout(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: a, b
        real(wp) :: q(2), p(2)
        character(len=:), allocatable :: source
        source = text([character(len=80) :: &
            "# a planar pendulum, written twice", &
            "", &
            "parameters g = 1, l = 1 m = 1", &
            "coordinates x, y", &
            "momenta  px  py    # comment", &
            "let  k = (px^2 + py^2)/(2*m), u = m*g*y", &
            "hamiltonian k \", &
            "   + u", &
            "constraint x^2 + y^2 - l^2", &
            "initial x = sin(1), y = -cos(1)"])
        call loaded(source, a, error)
        if (allocated(error)) return
        source = "coordinates" // achar(9) // "x y" // achar(13) // new_line("a") // &
            "momenta px,py" // achar(13) // new_line("a") // &
            "hamiltonian (px^2 + \  # the kinetic energy" // new_line("a") // &
            "  py^2)/2 + y" // new_line("a") // "constraint x^2 + y^2 - 1" // new_line("a") &
            // "initial x = sin(1), y = -cos(1), px = 0" // achar(13)
        call loaded(source, b, error)
        if (allocated(error)) return
        q = [0.3_wp, -0.7_wp]
        p = [0.2_wp, 0.1_wp]
        call check(error, a%hamiltonian(q, p) == b%hamiltonian(q, p), &
            "the two layouts give different H")
        if (allocated(error)) return
        call check(error, b%coordinate_name(2) == "y" .and. b%momentum_name(1) == "px" .and. &
            a%parameter_count() == 3 .and. a%parameter_name(3) == "m", "names")
    end subroutine grammar_layout

    !> Gradients and second derivatives of an H that uses every function and operation,
    !! against central differences.
    subroutine every_function(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        real(wp) :: q(3), p(3), g(3), gp(3), plus(3), minus(3), step, h1(3, 3), h2(3, 3)
        real(wp) :: h3(3, 3), hq(3, 3), shifted(3)
        integer :: k
        call loaded(text([character(len=100) :: "coordinates x y z", "momenta a b c", &
            "let s = sqrt(x^2 + 1) + exp(y/3) + log(z + 3) + sin(x*y) + cos(z)", &
            "let t = tan(x/2) + atan(y) + sinh(z/2) + cosh(x/3) + tanh(y*z)", &
            "let u = asin(x/3) + acos(y/4) + atan2(z, 2 + x) + atan(y, 3) + x^y/5 + 2^z", &
            "hamiltonian (a^2 + b*c + c^3)/(1 + x^2) + s*t/(1 + u^2) - u/x + (a*z)^-2"]), &
            model, error)
        if (allocated(error)) return
        q = [0.7_wp, 0.4_wp, 0.5_wp]
        p = [0.3_wp, -0.2_wp, 0.6_wp]
        step = epsilon(1.0_wp)**(1.0_wp / 3)
        call model%dh_dq(q, p, g)
        call model%dh_dp(q, p, gp)
        call model%hessian(q, p, h1, h2, h3)
        do k = 1, 3
            shifted = q
            shifted(k) = q(k) + step
            plus(1) = model%hamiltonian(shifted, p)
            shifted(k) = q(k) - step
            minus(1) = model%hamiltonian(shifted, p)
            call check(error, abs((plus(1) - minus(1)) / (2 * step) - g(k)) <= &
                1.0e3_wp * step**2 * (1 + abs(g(k))), "dH/dq" // int_str(k) // " " // &
                real_str(g(k)) // " against a difference " // &
                real_str((plus(1) - minus(1)) / (2 * step)))
            if (allocated(error)) return
            shifted = q
            shifted(k) = q(k) + step
            call model%dh_dq(shifted, p, plus)
            shifted(k) = q(k) - step
            call model%dh_dq(shifted, p, minus)
            hq(:, k) = (plus - minus) / (2 * step)
            shifted = p
            shifted(k) = p(k) + step
            plus(1) = model%hamiltonian(q, shifted)
            shifted(k) = p(k) - step
            minus(1) = model%hamiltonian(q, shifted)
            call check(error, abs((plus(1) - minus(1)) / (2 * step) - gp(k)) <= &
                1.0e3_wp * step**2 * (1 + abs(gp(k))), "dH/dp" // int_str(k))
            if (allocated(error)) return
        end do
        call check(error, maxval(abs(hq - h1)) <= 1.0e4_wp * step**2 * (1 + maxval(abs(h1))), &
            "d2H/dq2 against differences of the gradient: " // real_str(maxval(abs(hq - h1))))
    end subroutine every_function

    !> The bindings at many points (one pass of each tape over the points, in groups) give
    !! what the bindings of one point give at each, on every example model and on a model
    !! whose tapes are longer than the evaluator's fixed work array, at 1, 2, 3 and 5
    !! points (groups full and short).
    subroutine tapes_at_points(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        type(holosym_status_t) :: status
        character(len=:), allocatable :: long
        integer :: t, k
        do t = 1, size(examples) + 1
            if (t <= size(examples)) then
                call twin(examples(t), model, error)
                if (allocated(error)) return
            else
                long = "coordinates x y z" // new_line("a") // "momenta px py pz" // &
                    new_line("a") // "let w0 = 0" // new_line("a")
                do k = 1, 150
                    long = long // "let w" // int_str(k) // " = w" // int_str(k - 1) // &
                        " + 0.001*cos(z + " // int_str(k) // "/7)" // new_line("a")
                end do
                long = long // "hamiltonian (px^2 + py^2 + pz^2)/2 - sin(z) + w150" // &
                    new_line("a") // "constraint x^2 + y^2 + z^2 - 1" // new_line("a") // &
                    "initial x = 0, y = sqrt(2)/2, z = sqrt(2)/2, px = 0.6, py = 0, pz = 0"
                call model_from_text(long, model, status)
                call check(error, status%ok(), "long model: " // status%message)
                if (allocated(error)) return
                call check(error, maxval(model%tape_lengths()) > 512, "the long model's " // &
                    "tapes exceed the fixed work array")
                if (allocated(error)) return
            end if
            do k = 1, 5
                if (k == 4) cycle
                call compare_points(model, k, error)
                if (allocated(error)) then
                    if (t <= size(examples)) error%message = trim(examples(t)) // ": " // &
                        error%message
                    return
                end if
            end do
        end do
    end subroutine tapes_at_points

    !> Every binding at k points near the model's initial state against the binding of one
    !! point at each: equal (the same operations in the same order).
    subroutine compare_points(model, k, error)
        type(formula_model), intent(inout) :: model
        integer, intent(in) :: k
        type(test_error_t), allocatable, intent(inout) :: error
        type(holosym_status_t) :: status
        real(wp) :: q(model%n), p(model%n), qs(model%n, k), ps(model%n, k)
        real(wp) :: many(model%n, k), one(model%n, k), phi(model%m, k), phi_one(model%m, k)
        real(dp) :: low(model%n, k), low_one(model%n, k)
        real(wp), allocatable :: pv(:, :), pv_one(:, :)
        integer, allocatable :: rows(:), columns(:)
        integer :: i, j
        call model%initial_state(q, p, status)
        do j = 1, k
            do i = 1, model%n
                qs(i, j) = q(i) + 1.0e-3_wp * sin(real(3 * i + 7 * j, wp))
                ps(i, j) = p(i) + 1.0e-3_wp * cos(real(5 * i + 2 * j, wp))
            end do
        end do
        call model%dh_dq_points(qs, ps, many)
        do j = 1, k
            call model%dh_dq(qs(:, j), ps(:, j), one(:, j))
        end do
        call check(error, all(many == one), "dh_dq_points at " // int_str(k) // " points")
        if (allocated(error)) return
        call model%dh_dp_points(qs, ps, many)
        do j = 1, k
            call model%dh_dp(qs(:, j), ps(:, j), one(:, j))
        end do
        call check(error, all(many == one), "dh_dp_points at " // int_str(k) // " points")
        if (allocated(error)) return
        call model%dh_dq_double_points(real(qs, dp), real(ps, dp), low)
        do j = 1, k
            call model%dh_dq_double(real(qs(:, j), dp), real(ps(:, j), dp), low_one(:, j))
        end do
        call check(error, all(low == low_one), "dh_dq_double_points at " // int_str(k) // &
            " points")
        if (allocated(error) .or. model%m == 0) return
        call model%constraint_points(qs, phi)
        do j = 1, k
            call model%constraint(qs(:, j), phi_one(:, j))
        end do
        call check(error, all(phi == phi_one), "constraint_points at " // int_str(k) // &
            " points")
        if (allocated(error)) return
        call model%constraint_sparsity(rows, columns)
        allocate (pv(size(rows), k), pv_one(size(rows), k))
        call model%constraint_jacobian_values_points(qs, rows, columns, pv)
        do j = 1, k
            call model%constraint_jacobian_values(qs(:, j), rows, columns, pv_one(:, j))
        end do
        call check(error, all(pv == pv_one), "constraint_jacobian_values_points at " // &
            int_str(k) // " points")
    end subroutine compare_points

    !> The real64 evaluation of dH/dq agrees with the working-precision one to real64
    !! round-off on every example model.
    subroutine real64_tapes(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:), g(:)
        real(dp), allocatable :: gd(:)
        integer :: t
        do t = 1, size(examples)
            call twin(examples(t), model, error)
            if (allocated(error)) return
            allocate (q(model%n), p(model%n), g(model%n), gd(model%n))
            call model%initial_state(q, p, status)
            call model%dh_dq(q, p, g)
            call model%dh_dq_double(real(q, dp), real(p, dp), gd)
            call check(error, maxval(abs(real(gd, wp) - g)) <= &
                64 * epsilon(1.0_dp) * (1 + maxval(abs(g))), trim(examples(t)) // &
                ": real64 dH/dq differs by " // real_str(maxval(abs(real(gd, wp) - g))))
            if (allocated(error)) return
            deallocate (q, p, g, gd)
        end do
    end subroutine real64_tapes

    !> The separable form is found exactly where it holds, and the patterns are those of
    !! the formulas.
    subroutine structure_cases(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=60), parameter :: kinetic(*) = [character(len=60) :: &
            "(px^2 + py^2)/2", "px^2/2 + py^2/(2*3)", "(px - 1)^2/2 + py^2/2", &
            "-px^2/2 + py^2/2", "(px^2 + py^2)*(1 + x^2)/2", "px*py + py^2", &
            "px^4/4 + py^2/2"]
        logical, parameter :: separable(*) = [.true., .true., .false., .false., .false., &
            .false., .false.]
        type(formula_model) :: model
        real(wp) :: mass(2)
        integer, allocatable :: rows(:), cols(:)
        logical :: declared
        integer :: k
        do k = 1, size(kinetic)
            call loaded(text([character(len=100) :: "coordinates x y", "momenta px py", &
                "hamiltonian " // trim(kinetic(k)) // " + y", "constraint x^2 + y^2 - 1"]), &
                model, error)
            if (allocated(error)) return
            declared = model%diagonal_mass(mass)
            call check(error, declared .eqv. separable(k), "H = " // trim(kinetic(k)) // &
                ": separable form " // trim(merge("found    ", "not found", declared)))
            if (allocated(error)) return
        end do
        call check(error, declared .eqv. .false., "")
        call twin("spring_linkage", model, error)
        if (allocated(error)) return
        call model%potential_sparsity(rows, cols)
        call check(error, size(rows) == 2 .and. all(rows == [5, 6]) .and. all(cols == [5, 6]), &
            "the linkage's Hessian of U has the entries (5,5) and (6,6) alone")
        if (allocated(error)) return
        call model%constraint_sparsity(rows, cols)
        call check(error, size(rows) == 10, "the linkage's Phi has 10 nonzeros; found " // &
            int_str(size(rows)))
        if (allocated(error)) return
        call twin("chain8", model, error)
        if (allocated(error)) return
        call model%potential_sparsity(rows, cols)
        call check(error, size(rows) == 0, "the chain's potential is linear")
        if (allocated(error)) return
        call model%constraint_sparsity(rows, cols)
        call check(error, size(rows) == 4 * 8 - 2, "the chain's Phi has 4K - 2 nonzeros")
    end subroutine structure_cases

    !> Parameters set by name, those defined from them following; bad names and values
    !! refused with the model unchanged.
    subroutine parameters_by_name(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        type(holosym_status_t) :: status
        real(wp) :: value, mass(2), q(2), p(2)
        logical :: declared
        call loaded(text([character(len=80) :: "parameters m = 2, k = 3*m, r = 1/m", &
            "coordinates x y", "momenta px py", "hamiltonian (px^2 + py^2)/(2*m) + k*y", &
            "constraint x^2 + y^2 - 1", "initial x = 0, y = -1"]), model, error)
        if (allocated(error)) return
        call model%set_parameter("m", 4.0_wp, status)
        call check(error, status%ok(), status%message)
        if (allocated(error)) return
        call model%get_parameter("k", value, status)
        call check(error, value == 12, "k = 3 m follows m: " // real_str(value))
        if (allocated(error)) return
        declared = model%diagonal_mass(mass)
        call check(error, declared .and. all(mass == 4), "the masses follow m")
        if (allocated(error)) return
        call model%set_parameter("k", 1.0_wp, status)
        call model%set_parameter("m", 1.0_wp, status)
        call model%get_parameter("k", value, status)
        call check(error, value == 1, "k set by name stays: " // real_str(value))
        if (allocated(error)) return
        call model%set_parameter("n", 1.0_wp, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, status%message)
        if (allocated(error)) return
        call check(error, index(status%message, "no parameter 'n' (its parameters: m, k, r)") &
            > 0, status%message)
        if (allocated(error)) return
        call model%set_parameter("m", 0.0_wp, status)
        call check(error, index(status%message, "parameter 'r' cannot be computed: '/': " // &
            "division by zero") > 0, status%message)
        if (allocated(error)) return
        call model%get_parameter("m", value, status)
        call check(error, value == 1, "a refused value leaves the model unchanged")
        if (allocated(error)) return
        q = [0.0_wp, -1.0_wp]
        p = 0
        call check(error, model%hamiltonian(q, p) == -1, "H with k = 1 at y = -1")
    end subroutine parameters_by_name

    !> A start off the manifold is projected and said so; velocities become momenta; a
    !! model without a start says so; a start where the model cannot be used is refused.
    subroutine initial_states(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), position, velocity
        character(len=:), allocatable :: note
        character(len=*), parameter :: head = "coordinates x y" // new_line("a") // &
            "momenta px py" // new_line("a") // "hamiltonian (px^2 + py^2)/2 + y" // &
            new_line("a") // "constraint x^2 + y^2 - 1" // new_line("a")
        call loaded(head // "initial x = 0.6, y = -0.81, px = 1, py = 1", model, error)
        if (allocated(error)) return
        call model%initial_state(q, p, status, note)
        call check(error, status%ok() .and. index(note, "projected") > 0, "note: " // note)
        if (allocated(error)) return
        call manifold_check()
        if (allocated(error)) return
        call loaded(head // "initial x = 0.6, y = -0.8" // new_line("a") // &
            "velocity x = 0.8, y = 0.6", model, error)
        if (allocated(error)) return
        call model%initial_state(q, p, status, note)
        call check(error, status%ok() .and. abs(p(1) - 0.8_wp) <= 8 * eps .and. &
            abs(p(2) - 0.6_wp) <= 8 * eps, "tangent velocities are kept as momenta")
        if (allocated(error)) return
        call manifold_check()
        if (allocated(error)) return
        call loaded(head, model, error)
        if (allocated(error)) return
        call model%initial_state(q, p, status)
        call check(error, .not. status%ok() .and. index(status%message, "states no initial") &
            > 0, "no initial state: " // status%message)
    contains
        subroutine manifold_check()
            use holosym_manifold, only: manifold_residuals
            call manifold_residuals(model, q, p, position, velocity)
            call check(error, position <= 8 * eps .and. velocity <= 8 * eps, &
                "the start is not on the manifold: " // real_str(position) // ", " // &
                real_str(velocity))
        end subroutine manifold_check
    end subroutine initial_states

    !> The model text of a chain of K pendula (as tools/chain_model.py writes it, with
    !! unit masses and lengths): large enough that the graph grows many times while it is
    !! read and differentiated.
    function chain_text(links) result(source)
        integer, intent(in) :: links
        character(len=:), allocatable :: source
        character(len=16) :: i, j
        integer :: k
        source = "parameters m = 1, l = 1, g = 1" // new_line("a") // "coordinates"
        do k = 1, links
            write (i, '(i0)') k
            source = source // " x" // trim(i) // " y" // trim(i)
        end do
        source = source // new_line("a") // "momenta"
        do k = 1, links
            write (i, '(i0)') k
            source = source // " px" // trim(i) // " py" // trim(i)
        end do
        source = source // new_line("a") // "hamiltonian (0"
        do k = 1, links
            write (i, '(i0)') k
            source = source // " + px" // trim(i) // "^2 + py" // trim(i) // "^2"
        end do
        source = source // ")/(2*m) + g*m*(0"
        do k = 1, links
            write (i, '(i0)') k
            source = source // " + y" // trim(i)
        end do
        source = source // ")" // new_line("a") // "constraint x1^2 + y1^2 - l^2" // &
            new_line("a")
        do k = 2, links
            write (i, '(i0)') k
            write (j, '(i0)') k - 1
            source = source // "constraint (x" // trim(i) // " - x" // trim(j) // ")^2 + (y" &
                // trim(i) // " - y" // trim(j) // ")^2 - l^2" // new_line("a")
        end do
        ! The start at 0.5 rad: partial sums of the rods, as named subexpressions.
        source = source // "let dx = l*sin(0.5), dy = -l*cos(0.5)" // new_line("a") // &
            "let X1 = dx, Y1 = dy" // new_line("a")
        do k = 2, links
            write (i, '(i0)') k
            write (j, '(i0)') k - 1
            source = source // "let X" // trim(i) // " = X" // trim(j) // " + dx, Y" // &
                trim(i) // " = Y" // trim(j) // " + dy" // new_line("a")
        end do
        source = source // "initial"
        do k = 1, links
            write (i, '(i0)') k
            source = source // " x" // trim(i) // " = X" // trim(i) // ", y" // trim(i) // &
                " = Y" // trim(i)
        end do
    end function chain_text

    !> Chains of 56 to 66 links from formulas (the graph grows past its first capacity at
    !! a different statement for each) start where the built-in chain starts; for 64 links
    !! every binding equals the built-in chain's at a generic point, and the derived
    !! patterns are the chain's.
    subroutine large_chain(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model) :: model
        type(pendulum_chain) :: chain
        real(wp) :: q(128), p(128), a(128), b(128), phi_a(64), phi_b(64)
        real(wp), allocatable :: values_a(:), jb(:, :)
        integer, allocatable :: rows(:), cols(:)
        real(dp) :: ad(128), bd(128)
        real(wp), allocatable :: q0(:), p0(:), qc(:), pc(:)
        type(holosym_status_t) :: status
        type(command_result_t) :: result
        integer :: k, links
        do links = 56, 66, 2
            call loaded(chain_text(links), model, error)
            if (allocated(error)) return
            call same_start()
            if (allocated(error)) return
            ! The file tools/chain_model.py writes (at 60 and 64 links the graph grows while
            ! a simplification passes an operand read from the graph's own arrays).
            call run_shell("python3 tools/chain_model.py " // int_str(links) // " " // &
                scratch_path("chain.hsm"), result)
            if (result%exit_code /= 0) cycle
            call load_model(scratch_path("chain.hsm"), model, status)
            call check(error, status%ok(), status%message)
            if (allocated(error)) return
            call same_start()
            if (allocated(error)) return
        end do
        call loaded(chain_text(64), model, error)
        if (allocated(error)) return
        chain = pendulum_chain(64)
        call chain%state_from_angles([(0.01_wp * k, k = 1, 64)], [(0.02_wp * k, k = 1, 64)], &
                                     q, p)
        call check(error, abs(model%hamiltonian(q, p) - chain%hamiltonian(q, p)) <= &
            64 * eps * abs(chain%hamiltonian(q, p)), "H")
        call model%dh_dq(q, p, a)
        call chain%dh_dq(q, p, b)
        call check(error, all(a == b), "dH/dq")
        call model%dh_dp(q, p, a)
        call chain%dh_dp(q, p, b)
        call check(error, all(a == b), "dH/dp")
        call model%dh_dq_double(real(q, dp), real(p, dp), ad)
        call chain%dh_dq_double(real(q, dp), real(p, dp), bd)
        call check(error, all(ad == bd), "dH/dq in real64")
        call model%constraint(q, phi_a)
        call chain%constraint(q, phi_b)
        call check(error, maxval(abs(phi_a - phi_b)) <= 16 * eps, "phi")
        if (allocated(error)) return
        call model%constraint_sparsity(rows, cols)
        call check(error, size(rows) == 4 * 64 - 2, "Phi has 4K - 2 nonzeros")
        allocate (values_a(size(rows)), jb(64, 128))
        call model%constraint_jacobian_values(q, rows, cols, values_a)
        call chain%constraint_jacobian(q, jb)
        call check(error, all([(values_a(k) == jb(rows(k), cols(k)), k = 1, size(rows))]), &
            "Phi's values at the pattern")
        call model%potential_sparsity(rows, cols)
        call check(error, size(rows) == 0, "the potential is linear")
    contains
        subroutine same_start()
            allocate (q0(2 * links), p0(2 * links), qc(2 * links), pc(2 * links))
            call model%initial_state(q0, p0, status)
            chain = pendulum_chain(links)
            call chain%state_from_angles([(0.5_wp, k = 1, links)], [(0.0_wp, k = 1, links)], &
                                         qc, pc)
            call check(error, status%ok() .and. all(q0 == qc) .and. all(p0 == pc), &
                int_str(links) // " links: the start differs from the built-in chain's " // &
                status%message)
            deallocate (q0, p0, qc, pc)
        end subroutine same_start
    end subroutine large_chain

    !> The value of `quantity`(index) of `system` in the reference file (NaN-free: fails
    !! the test when absent).
    subroutine reference_values(system, quantity, count, values, error)
        character(len=*), intent(in) :: system, quantity
        integer, intent(in) :: count
        real(wp), intent(out) :: values(count)
        type(test_error_t), allocatable, intent(inout) :: error
        character(len=256) :: line
        character(len=:), allocatable :: field
        integer :: unit, ios, k, found
        values = 0
        found = 0
        open (newunit=unit, file="test/data/formula_reference.csv", status="old", &
              action="read", iostat=ios)
        call check(error, ios == 0, "cannot open test/data/formula_reference.csv")
        if (allocated(error)) return
        do
            read (unit, '(a)', iostat=ios) line
            if (ios /= 0) exit
            if (line(1:1) == "#") cycle
            if (split_field(line, 1, ",") /= system) cycle
            if (split_field(line, 2, ",") /= quantity) cycle
            field = split_field(line, 3, ",")
            read (field, *) k
            field = split_field(line, 4, ",")
            read (field, *) values(k)
            found = found + 1
        end do
        close (unit)
        call check(error, found == count, system // " " // quantity // ": " // &
            int_str(found) // " values in the reference file")
    end subroutine reference_values

    !> The water molecule and the four-bar linkage, from their model files, agree with
    !! independent 50-digit solutions (tools/reference/formula_reference.py, written from
    !! the formulas; its start is computed from the files exactly) at the start and at
    !! T = 10: (8, 7, 9) with h = 1/16 (water) and 1/128 (the faster four-bar) reach
    !! round-off.
    subroutine independent_references(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(2) = ["water  ", "fourbar"]
        integer, parameter :: steps(2) = [160, 1280]
        type(formula_model) :: model
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:), q_ref(:), p_ref(:)
        real(wp) :: start, final
        integer :: k
        do k = 1, 2
            call twin(names(k), model, error)
            if (allocated(error)) return
            allocate (q(model%n), p(model%n), q_ref(model%n), p_ref(model%n))
            call model%initial_state(q, p, status)
            call reference_values(trim(names(k)), "q0", model%n, q_ref, error)
            call reference_values(trim(names(k)), "p0", model%n, p_ref, error)
            if (allocated(error)) return
            start = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
            call check(error, start <= 1.0e-33_wp .or. wp_is_double, trim(names(k)) // &
                ": the start differs from the reference's by " // real_str(start))
            if (allocated(error)) return
            call integ%init(model, 8, 7, 9, status)
            call integ%integrate(model, q, p, 10.0_wp / steps(k), steps(k), status=status)
            call check(error, status%ok(), trim(names(k)) // ": " // status%message)
            if (allocated(error)) return
            call reference_values(trim(names(k)), "qT", model%n, q_ref, error)
            call reference_values(trim(names(k)), "pT", model%n, p_ref, error)
            if (allocated(error)) return
            final = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
            call check(error, final <= max(1.0e-30_wp, 1.0e4_wp * eps), trim(names(k)) // &
                ": at T = 10 the state differs from the reference's by " // real_str(final))
            if (allocated(error)) return
            deallocate (q, p, q_ref, p_ref)
        end do
    end subroutine independent_references

    !> A few thousand model files mutated from the examples (fixed seed: characters
    !! deleted, inserted, replaced by operators, digits, control bytes or other bytes; lines
    !! dropped, repeated, swapped or cut; numbers made huge, tiny or zero): each is loaded
    !! or refused with HOLOSYM_INVALID_MODEL and a message that starts with the source
    !! name, never a crash. A loaded model with an initial state must give it on its
    !! manifold with H finite, and take a step or fail with a status. In the build that
    !! traps floating-point exceptions, the mutants lose their initial state (the
    !! projection evaluates the user's formulas at points nobody checked: there NaN is the
    !! user's, and traps). Bounded: at most 60 s.
    subroutine fuzz_models(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: mutants = 3000
        character(len=*), parameter :: alphabet = "+-*/^(),=#\ .eE0123456789xyzpqabl_" // &
            "sincoaqrtlgeh"
        character(len=16), parameter :: numbers(*) = [character(len=16) :: "0", "1e4000", &
            "1e-4000", "-1", "1e400", "0.0", "1e-30", "2e3000", "99999999999999999999"]
        type(text_line_t), allocatable :: seeds(:)
        type(formula_model) :: model
        type(constrained_integrator) :: integ
        type(step_info_t) :: info
        type(holosym_status_t) :: status
        character(len=:), allocatable :: source
        real(wp), allocatable :: q(:), p(:)
        integer(int64) :: state, start, now, rate
        integer :: k, loaded_count, refused, stepped
        logical :: trapping
        trapping = overflow_traps()
        call seed_texts(seeds)
        state = 20261202_int64
        loaded_count = 0
        refused = 0
        stepped = 0
        call system_clock(start, rate)
        do k = 1, mutants
            source = mutate(seeds(1 + modulo(k, size(seeds)))%text)
            if (trapping) source = without_initial(source)
            call model_from_text(source, model, status, name="fuzz")
            if (status%ok()) then
                loaded_count = loaded_count + 1
                call loaded_model_works()
            else
                refused = refused + 1
                call check(error, status%code == HOLOSYM_INVALID_MODEL .and. &
                    index(status%message, "fuzz:") == 1, "mutant " // int_str(k) // &
                    ": code " // int_str(status%code) // ", message '" // status%message // &
                    "' for" // new_line("a") // source)
            end if
            if (allocated(error)) return
            call system_clock(now)
            if (real(now - start) / rate > 60) exit
        end do
        ! The mutants must reach both outcomes, or the test says little.
        call check(error, loaded_count > 100 .and. refused > 100, "loaded " // &
            int_str(loaded_count) // ", refused " // int_str(refused))
    contains
        subroutine loaded_model_works()
            character(len=:), allocatable :: note
            real(wp) :: position, velocity
            if (.not. model%has_initial_state()) return
            allocate (q(model%n), p(model%n))
            call model%initial_state(q, p, status, note)
            call check(error, status%ok(), "a loaded mutant's initial state fails: " // &
                status%message // new_line("a") // source)
            if (.not. allocated(error)) then
                call manifold_residuals(model, q, p, position, velocity)
                call check(error, is_finite(model%hamiltonian(q, p)) .and. &
                    position <= 1.0e-6_wp * (1 + maxval(abs(q))), &
                    "a loaded mutant's start is not usable" // new_line("a") // source)
            end if
            if (.not. allocated(error) .and. stepped < 200) then
                call integ%init(model, 2, 1, 3, status)
                if (status%ok()) call integ%step(model, q, p, 0.01_wp, info, status)
                stepped = stepped + 1
            end if
            deallocate (q, p)
        end subroutine loaded_model_works
        !> A pseudo-random integer in 0..range-1 (a 64-bit LCG's high bits, no overflow).
        integer function random(range)
            integer, intent(in) :: range
            state = modulo(state * 48271_int64, 2147483647_int64)
            random = int(modulo(state, int(range, int64)))
        end function random
        function mutate(text) result(out)
            character(len=*), intent(in) :: text
            character(len=:), allocatable :: out
            integer :: edits, e, at, kind, length, c
            out = text
            edits = 1 + random(4)
            do e = 1, edits
                length = len(out)
                at = 1 + random(max(1, length))
                kind = random(10)
                select case (kind)
                case (0)
                    if (length > 0) out = out(:at - 1) // out(at + 1:)
                case (1, 2)
                    c = 1 + random(len(alphabet))
                    out = out(:at - 1) // alphabet(c:c) // out(at:)
                case (3)
                    out = out(:at - 1) // achar(random(256)) // out(at:)
                case (4)
                    out = out(:at - 1) // trim(numbers(1 + random(size(numbers)))) // out(at:)
                case (5)
                    out = out(:at - 1) // new_line("a") // out(at:)
                case (6)
                    out = out(:at - 1)
                case (7)
                    out = out // out(at:)
                case (8)
                    c = 1 + random(len(alphabet))
                    if (length > 0) out(at:at) = alphabet(c:c)
                case default
                    out = out(:at - 1) // " \" // new_line("a") // out(at:)
                end select
            end do
        end function mutate
    end subroutine fuzz_models

    !> The text without its initial and velocity statements.
    function without_initial(text) result(out)
        character(len=*), intent(in) :: text
        character(len=:), allocatable :: out
        integer :: first, last
        out = ""
        first = 1
        do while (first <= len(text))
            last = index(text(first:), new_line("a"))
            if (last == 0) then
                last = len(text)
            else
                last = first + last - 1
            end if
            if (index(text(first:last), "initial") == 0 .and. &
                index(text(first:last), "velocit") == 0) out = out // text(first:last)
            first = last + 1
        end do
    end function without_initial

    !> The example model files (and two small models) as the fuzz test's seeds.
    subroutine seed_texts(seeds)
        type(text_line_t), allocatable, intent(out) :: seeds(:)
        integer :: t, ios
        type(text_line_t), allocatable :: lines(:)
        allocate (seeds(size(examples) + 2))
        do t = 1, size(examples)
            call read_lines(model_dir // trim(examples(t)) // ".hsm", lines, ios)
            seeds(t)%text = ""
            do ios = 1, size(lines)
                seeds(t)%text = seeds(t)%text // lines(ios)%text // new_line("a")
            end do
        end do
        seeds(size(examples) + 1)%text = text([character(len=60) :: "coordinates x y", &
            "momenta px py", "hamiltonian (px^2 + py^2)/2 + y", "constraint x^2 + y^2 - 1", &
            "initial x = 1, y = 0"])
        seeds(size(examples) + 2)%text = text([character(len=60) :: "parameters a = 2", &
            "coordinates x", "momenta p", "let u = a*x^2", "hamiltonian p^2/2 + u"])
    end subroutine seed_texts

    !> Every syntax or meaning error is refused with code HOLOSYM_INVALID_MODEL and a
    !! message that says where (line:column) and what was expected.
    subroutine error_messages(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: lf = new_line("a")
        character(len=*), parameter :: xy = "coordinates x y" // lf // "momenta px py" // lf
        character(len=*), parameter :: h = "hamiltonian (px^2 + py^2)/2 + y" // lf
        type(formula_model) :: model
        type(holosym_status_t) :: status
        character(len=:), allocatable :: deep, long
        integer :: k
        k = 0
        deep = repeat("(", 300) // "x" // repeat(")", 300)
        ! 10 MB on the heap (a temporary of that size can overflow a compiler's stack).
        allocate (character(len=10000002) :: long)
        long(1:2) = "# "
        do k = 3, len(long)
            long(k:k) = "a"
        end do
        k = 0
        call expect(xy // "hamiltonian px^2 + z", "model:3:20: unknown name 'z'")
        call expect(xy // "hamiltonian px^2 + xx", "unknown name 'xx' (did you mean 'x'?)")
        call expect("coordinates x y x", "model:1:17: 'x' is declared twice (first as a " // &
            "coordinate, at line 1)")
        call expect("coordinates x y" // lf // "momenta px", "model:2:9: 1 momenta for 2 " // &
            "coordinates")
        call expect(xy // "constraint x^2 + y^2 - 1", "model: no hamiltonian statement")
        call expect(xy // "constraint x - 1" // lf // "constraint y - 1" // lf // h, &
            "model:4:1: 2 constraints for 2 coordinates")
        call expect(xy // "hamiltonian r + px^2 + py^2" // lf // "let r = x^2", &
            "model:3:13: 'r' is used before its definition (line 4)")
        call expect(xy // "hamiltonian sin(x, y) + px^2", "model:3:13: sin takes 1 " // &
            "argument; got 2")
        call expect(xy // "hamiltonian atan2(x) + px^2", "atan2 takes 2 arguments")
        call expect(xy // "hamiltonian 1e5000*x + px^2", "model:3:13: the number 1e5000 " // &
            "is out of range")
        call expect(xy // "let a = a + 1", "model:3:9: 'a' is used in its own definition")
        call expect(xy // "let a = b" // lf // "let b = a", "'b' is used before its " // &
            "definition (line 4)")
        call expect("coordinates x" // achar(0) // "y", "model:1:14: not text: control " // &
            "character 0")
        call expect(long, "model:1:1: the line is longer than 1048576 characters")
        call expect("", "model: the model is empty: expected coordinates")
        call expect("# nothing" // lf // lf, "model: the model is empty (2 lines of " // &
            "comments and blanks)")
        call expect(xy // "hamiltonain px^2", "model:3:1: unknown statement 'hamiltonain' " // &
            "(did you mean 'hamiltonian'?)")
        call expect(xy // h // "constraint px - 1", "model:4:12: the constraint depends " // &
            "on momentum 'px'")
        call expect(xy // h // "constraint 2 - 1", "the constraint depends on no coordinate")
        call expect(xy // "hamiltonian (px^2 + py^2/2", "model:3:27: expected ')'; got " // &
            "the end of the line")
        call expect(xy // "hamiltonian px^2 x", "model:3:18: expected an operator or the " // &
            "end of the line after the expression; got 'x'")
        call expect(xy // "parameters a = x", "model:3:12: parameter 'a' depends on " // &
            "coordinate 'x'")
        call expect(xy // h // "initial x = 1", "model:4:1: the initial state gives no " // &
            "value for coordinate 'y'")
        call expect(xy // h // "initial x = 1, y = 0, px = 1" // lf // "velocity y = 1", &
            "model:5:10: the initial state gives both momenta and velocities")
        call expect(xy // h // "initial x = 1, y = 0, x = 2", "model:4:23: the initial " // &
            "value of 'x' is given twice")
        call expect(xy // h // "initial x = y, y = 0", "model:4:9: the initial value of " // &
            "'x' depends on coordinate 'y'")
        call expect(xy // "hamiltonian px @ 2", "model:3:16: unexpected character '@'")
        call expect("coordinates x " // achar(195) // achar(169), "model:1:15: unexpected " // &
            "byte 195")
        call expect("coordinates sin y", "model:1:13: 'sin' is a function or constant")
        call expect("coordinates let y", "'let' is a keyword")
        call expect(xy // "hamiltonian sin + px", "model:3:13: 'sin' is a function: " // &
            "write sin(...)")
        call expect(xy // "hamiltonian " // deep, "nested deeper than 256 levels")
        call expect("momenta px py", "model:1:1: momenta before coordinates")
        call expect(xy // h // h, "model:4:1: a second hamiltonian (the first is at line 3)")
        call expect(xy // "hamiltonian 1.2.3*x", "model:3:13: malformed number '1.2.3'")
        call expect(xy // "hamiltonian 2x", "malformed number '2x'")
        call expect("parameters a = 1/0" // lf // xy // h, "model:1:17: the value of " // &
            "parameter 'a' cannot be computed: '/': division by zero")
        call expect(xy // "hamiltonian log(x) + px^2 + py^2" // lf // &
            "initial x = -1, y = 0", "model:3:13: H is not finite at the initial state: " // &
            "log: argument outside the domain")
        call expect(xy // h // "constraint x^2 + y^2 - 1" // lf // "initial x = 1, y = 0" // &
            lf // "coordinates z", "the coordinates are declared already")
        call expect("coordinates x y z" // lf // "momenta px py pz" // lf // &
            "hamiltonian (px^2 + py^2 + pz^2)/2" // lf // "constraint x^2 + y^2 - 1" // lf // &
            "constraint 2*x^2 + 2*y^2 - 2" // lf // "initial x = 1, y = 0, z = 0", &
            "model:6: the constraints are dependent at the initial state")
        call expect(xy // h // "constraint x^2 + y^2 + 1" // lf // "initial x = 1, y = 0", &
            "model:5: the initial state cannot be brought onto the constraint manifold")
        call expect(xy // h // "initial x = 1, y = 0, z = 1", "model:4:23: unknown name 'z'")
        call expect(xy // h // "velocity px = 1", "'px' is a momentum; the initial state " // &
            "gives velocities of coordinates")
        call expect(xy // "let = 3", "model:3:5: expected a let name; got '='")
        call expect(xy // "parameters a 3", "model:3:14: expected '=' after 'a'; got '3'")
        call expect(xy // "hamiltonian", "model:3:12: expected the expression of the " // &
            "Hamiltonian; got the end of the line")
        call expect(xy // "hamiltonian px^2 + ", "expected a number, a name or '('; got " // &
            "the end of the line")
        call load_model("build/no such directory/model.hsm", model, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_MODEL, status%message)
        if (allocated(error)) return
        call check(error, index(status%message, "build/no such directory/model.hsm: ") == 1, &
            status%message)
    contains
        subroutine expect(source, message)
            character(len=*), intent(in) :: source, message
            if (allocated(error)) return
            k = k + 1
            call model_from_text(source, model, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_MODEL, &
                "case " // int_str(k) // " (" // message // "): " // status%message)
            if (allocated(error)) return
            call check(error, index(status%message, message) > 0, "case " // int_str(k) // &
                ": expected '" // message // "'; got '" // status%message // "'")
        end subroutine expect
    end subroutine error_messages

end module test_formula
