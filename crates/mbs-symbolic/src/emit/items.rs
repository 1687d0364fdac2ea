//! The items of the generated module around the methods: the struct of run-time parameters
//! (private, with the cache of parameter-only subexpressions), its constructors
//! (`with_params`, `Default`), the inherent `impl` (constants, `param` and the methods) and
//! the `runtime::Mechanism<N, NC>` implementation.

use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::model::{CoordinateUnit, Model};

/// What the items need to know about the model.
pub(super) struct Items<'a> {
    /// The model.
    pub model: &'a Model,
    /// The struct's name.
    pub sname: &'a Ident,
    /// Path of the runtime module.
    pub rt: &'a syn::Path,
    /// Field names of the parameters, by parameter index.
    pub param_idents: &'a [Ident],
    /// Number of coordinates.
    pub n: usize,
    /// Number of constraint rows.
    pub nc: usize,
    /// Number of hoisted parameter-only subexpressions (the length of the cache).
    pub hoisted: usize,
    /// Name of the cache field (only when `hoisted > 0`).
    pub cache_field: &'a Ident,
}

/// A float literal token (the value is finite: parameter values are validated).
fn float_token(v: f64) -> TokenStream {
    let lit = Literal::f64_unsuffixed(v.abs());
    if v < 0.0 {
        quote! { (-#lit) }
    } else {
        quote! { #lit }
    }
}

impl Items<'_> {
    /// The run-time parameters with their field names.
    fn runtime_params(&self) -> impl Iterator<Item = (&crate::model::Parameter, &Ident)> {
        self.model
            .parameters
            .iter()
            .zip(self.param_idents)
            .filter(|(p, _)| p.runtime)
    }

    /// `self.<cache> = self.hoisted_values();`, or nothing without a cache.
    fn refresh(&self) -> TokenStream {
        if self.hoisted == 0 {
            return TokenStream::new();
        }
        let cache = self.cache_field;
        quote! { self.#cache = self.hoisted_values(); }
    }

    /// The struct: one private `f64` field per run-time parameter, and the cache of the
    /// parameter-only subexpressions.
    pub fn struct_item(&self) -> TokenStream {
        let mut fields = TokenStream::new();
        for (p, id) in self.runtime_params() {
            let doc = format!(" Parameter `{}` (default {}).", p.name, p.value);
            fields.extend(quote! { #[doc = #doc] #id: f64, });
        }
        if self.hoisted > 0 {
            let (cache, len) = (self.cache_field, Literal::usize_unsuffixed(self.hoisted));
            fields.extend(quote! {
                /// Parameter-only subexpressions (`hoisted_values`), refreshed whenever a
                /// parameter changes.
                #cache: [f64; #len],
            });
        }
        let struct_doc = format!(
            " Generated equations of the `{}` mechanism: {} coordinates, {} constraint rows. The run-time parameters are private fields: build with `with_params` or `Default`, change them with `Mechanism::set_param` (which refreshes the cache of parameter-only subexpressions), read them with `param`.",
            self.model.name, self.n, self.nc
        );
        let sname = self.sname;
        quote! {
            #[doc = #struct_doc]
            #[derive(Clone, Copy, Debug, PartialEq)]
            #[allow(non_snake_case)]
            pub struct #sname { #fields }
        }
    }

    /// `Default`: the parameter values of the model file.
    pub fn default_impl(&self) -> TokenStream {
        let defaults: Vec<TokenStream> = self
            .runtime_params()
            .map(|(p, _)| float_token(p.value))
            .collect();
        let sname = self.sname;
        // Fully qualified: a model named `default` gives a struct `Default`, which would
        // shadow the prelude trait.
        quote! {
            #[allow(clippy::all)]
            impl ::core::default::Default for #sname {
                fn default() -> Self { Self::with_params([#(#defaults),*]) }
            }
        }
    }

    /// The inherent `impl`: sizes and names as constants, `with_params`, `param`, then
    /// `methods`.
    pub fn inherent_impl(&self, names: &Names<'_>, methods: TokenStream) -> TokenStream {
        let (nl, ncl) = (
            Literal::usize_unsuffixed(self.n),
            Literal::usize_unsuffixed(self.nc),
        );
        let runtime_names: Vec<&str> = self
            .runtime_params()
            .map(|(p, _)| p.name.as_str())
            .collect();
        let npar = Literal::usize_unsuffixed(runtime_names.len());
        let npts = Literal::usize_unsuffixed(names.points.len());
        let (point_names, coord_names, cons_names) =
            (&names.points, &names.coordinates, &names.constraints);
        let rt = self.rt;
        let units = names.units.iter().map(|u| match u {
            CoordinateUnit::Angle => quote! { #rt::CoordinateUnit::Angle },
            CoordinateUnit::Length => quote! { #rt::CoordinateUnit::Length },
        });
        let mut inits = TokenStream::new();
        let mut getters = TokenStream::new();
        for (k, (p, id)) in self.runtime_params().enumerate() {
            let (kl, name) = (Literal::usize_unsuffixed(k), &p.name);
            inits.extend(quote! { #id: values[#kl], });
            getters.extend(quote! { #name => Some(self.#id), });
        }
        if self.hoisted > 0 {
            let (cache, len) = (self.cache_field, Literal::usize_unsuffixed(self.hoisted));
            inits.extend(quote! { #cache: [0.0; #len], });
        }
        let values = if runtime_names.is_empty() {
            format_ident!("_values")
        } else {
            format_ident!("values")
        };
        let name_arg = if runtime_names.is_empty() {
            format_ident!("_name")
        } else {
            format_ident!("name")
        };
        let refresh = self.refresh();
        let sname = self.sname;
        quote! {
            #[allow(non_snake_case, unused_parens, dead_code, clippy::all)]
            impl #sname {
                /// Number of joint coordinates.
                pub const DOF: usize = #nl;
                /// Number of constraint rows.
                pub const CONSTRAINTS: usize = #ncl;
                /// Names of the run-time parameters.
                pub const PARAM_NAMES: [&'static str; #npar] = [#(#runtime_names),*];
                /// Names of the named points.
                pub const POINT_NAMES: [&'static str; #npts] = [#(#point_names),*];
                /// Names of the joint coordinates.
                pub const COORDINATE_NAMES: [&'static str; #nl] = [#(#coord_names),*];
                /// Names of the constraint rows.
                pub const CONSTRAINT_NAMES: [&'static str; #ncl] = [#(#cons_names),*];
                /// What each joint coordinate measures (angle or length).
                pub const COORDINATE_UNITS: [#rt::CoordinateUnit; #nl] = [#(#units),*];
                /// The mechanism with the run-time parameters `values`, in the order of
                /// `PARAM_NAMES`.
                pub fn with_params(#values: [f64; #npar]) -> Self {
                    let mut s = Self { #inits };
                    s.refresh_hoisted();
                    s
                }
                /// The value of the run-time parameter `name`, `None` when there is none.
                pub fn param(&self, #name_arg: &str) -> Option<f64> {
                    match #name_arg { #getters _ => None }
                }
                /// Recomputes the cache of parameter-only subexpressions.
                #[inline]
                fn refresh_hoisted(&mut self) { #refresh }
                #methods
            }
        }
    }

    /// `impl runtime::Mechanism<N, NC>`: forwards to the inherent methods; `point_fns` are the
    /// point methods by point index, `position_fns` their position-and-Jacobian-only
    /// counterparts.
    pub fn mechanism_impl(&self, point_fns: &[Ident], position_fns: &[Ident]) -> TokenStream {
        let (nl, ncl) = (
            Literal::usize_unsuffixed(self.n),
            Literal::usize_unsuffixed(self.nc),
        );
        let npts = Literal::usize_unsuffixed(point_fns.len());
        let mut setters = TokenStream::new();
        for (p, id) in self.runtime_params() {
            let name = &p.name;
            setters.extend(quote! { #name => self.#id = value, });
        }
        // Without run-time parameters `set_param` never reads the value.
        let value_arg = if self.runtime_params().next().is_none() {
            format_ident!("_value")
        } else {
            format_ident!("value")
        };
        let mut point_arms = TokenStream::new();
        for (k, fname) in point_fns.iter().enumerate() {
            let kl = Literal::usize_unsuffixed(k);
            point_arms.extend(quote! { #kl => self.#fname(q, qd, out), });
        }
        let mut position_arms = TokenStream::new();
        for (k, fname) in position_fns.iter().enumerate() {
            let kl = Literal::usize_unsuffixed(k);
            position_arms.extend(quote! { #kl => self.#fname(q, p, j), });
        }
        let (sname, rt) = (self.sname, self.rt);
        let has_elements = !self.model.forces.is_empty();
        quote! {
            #[allow(clippy::all)]
            impl #rt::Mechanism<#nl, #ncl> for #sname {
                const FORCE_ELEMENTS: bool = #has_elements;
                fn param_names(&self) -> &[&'static str] { &Self::PARAM_NAMES }
                fn set_param(&mut self, name: &str, #value_arg: f64) -> bool {
                    match name { #setters _ => return false, }
                    #[allow(unreachable_code)]
                    {
                        self.refresh_hoisted();
                        true
                    }
                }
                fn point_names(&self) -> &[&'static str] { &Self::POINT_NAMES }
                fn coordinate_units(&self) -> &[#rt::CoordinateUnit] { &Self::COORDINATE_UNITS }
                fn mass_matrix(&self, q: &[f64; #nl], m: &mut [[f64; #nl]; #nl]) { #sname::mass_matrix(self, q, m) }
                fn f_vector(&self, q: &[f64; #nl], qd: &[f64; #nl], f: &mut [f64; #nl]) { #sname::f_vector(self, q, qd, f) }
                fn q_vector(&self, q: &[f64; #nl], qd: &[f64; #nl], t: f64, out: &mut [f64; #nl]) { #sname::q_vector(self, q, qd, t, out) }
                fn constraints(&self, q: &[f64; #nl], h: &mut [f64; #ncl]) { #sname::constraints(self, q, h) }
                fn constraint_jacobian(&self, q: &[f64; #nl], j: &mut [[f64; #nl]; #ncl]) { #sname::constraint_jacobian(self, q, j) }
                fn constraint_bias(&self, q: &[f64; #nl], qd: &[f64; #nl], a: &mut [f64; #ncl]) { #sname::constraint_bias(self, q, qd, a) }
                fn evaluate(&self, q: &[f64; #nl], qd: &[f64; #nl], t: f64, out: &mut #rt::Evaluation<#nl, #ncl>) { #sname::evaluate(self, q, qd, t, out) }
                fn evaluate_with_points(&self, q: &[f64; #nl], qd: &[f64; #nl], t: f64, out: &mut #rt::Evaluation<#nl, #ncl>, points: &mut [#rt::PointKinematics<#nl>]) -> bool {
                    match <&mut [#rt::PointKinematics<#nl>; #npts]>::try_from(points) {
                        Ok(points) => {
                            #sname::evaluate_with_points(self, q, qd, t, out, points);
                            true
                        }
                        Err(_) => false,
                    }
                }
                fn potential_energy(&self, q: &[f64; #nl]) -> f64 { #sname::potential_energy(self, q) }
                fn element_power(&self, q: &[f64; #nl], qd: &[f64; #nl]) -> [f64; 2] { #sname::element_power(self, q, qd) }
                fn gravity_load_jacobian(&self, q: &[f64; #nl], g: &mut [[f64; 3]; #nl]) { #sname::gravity_load_jacobian(self, q, g) }
                fn point_kinematics(&self, k: usize, q: &[f64; #nl], qd: &[f64; #nl], out: &mut #rt::PointKinematics<#nl>) -> bool {
                    match k { #point_arms _ => return false, }
                    #[allow(unreachable_code)]
                    true
                }
                fn point_position(&self, k: usize, q: &[f64; #nl], p: &mut [f64; 3], j: &mut [[f64; #nl]; 3]) -> bool {
                    match k { #position_arms _ => return false, }
                    #[allow(unreachable_code)]
                    true
                }
            }
        }
    }
}

/// Names of the points, coordinates and constraint rows, in index order.
pub(super) struct Names<'a> {
    /// Point names.
    pub points: Vec<&'a str>,
    /// Coordinate names.
    pub coordinates: Vec<&'a str>,
    /// Constraint row names.
    pub constraints: Vec<&'a str>,
    /// Coordinate units (from the joint types).
    pub units: Vec<CoordinateUnit>,
}
