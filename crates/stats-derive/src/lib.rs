//! `#[derive(Stats)]`: merging of rtsim's typed statistics structs, field by field.
//!
//! Stats are plain structs of counters, summed across units, channels and worker threads with
//! `+=` (`../shared/STYLE.md` §7). Writing that `AddAssign` by hand invites the classic bug: a
//! new counter is added to the struct and forgotten in the sum, and the totals silently lose it.
//! This derive writes both `impl AddAssign<&T> for T` and `impl AddAssign<T> for T` from the
//! field list, so every field is merged — a field cannot be left out.
//!
//! How a field is merged follows its type, recursively:
//!
//! - a scalar or any type with `AddAssign<&Self>` (integers, floats, `rtsim_core::stats::Histogram`,
//!   another `#[derive(Stats)]` struct): `a += &b`;
//! - an array `[T; N]`: element by element;
//! - a `Vec<T>`: element by element, growing the left side to the longer length with
//!   `T::default()` first (per-tag or per-bank tables whose length is only known at run time).
//!
//! The field attribute `#[stats(max)]` merges by maximum instead (`if b > a { a = b.clone() }`,
//! element-wise for arrays and Vecs): high-water marks such as the largest queue occupancy, or
//! the simulated end cycle that every channel shares. Unknown attribute arguments, enums and
//! unions are compile errors. The derive is re-exported as `rtsim_sim::Stats`.
//!
//! ```ignore
//! #[derive(Clone, Debug, Default, rtsim_sim::Stats)]
//! struct LinkStats {
//!     pushes: u64,
//!     latency: Histogram,       // AddAssign<&Histogram>
//!     per_bank: Vec<u64>,       // element-wise, growing
//!     #[stats(max)]
//!     max_occupancy: u64,       // merged by maximum
//! }
//! ```

use proc_macro::TokenStream;
use proc_macro2::TokenStream as Tokens;
use quote::{format_ident, quote};
use syn::{Data, DeriveInput, Fields, GenericArgument, PathArguments, Type, parse_macro_input};

/// How a field is combined with the other side's.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Merge {
    Sum,
    Max,
}

/// Derive `AddAssign<&Self>` and `AddAssign<Self>` merging every field (see the crate docs).
#[proc_macro_derive(Stats, attributes(stats))]
pub fn derive_stats(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as DeriveInput);
    match expand(&input) {
        Ok(t) => t.into(),
        Err(e) => e.to_compile_error().into(),
    }
}

fn expand(input: &DeriveInput) -> syn::Result<Tokens> {
    let name = &input.ident;
    let fields = match &input.data {
        Data::Struct(s) => &s.fields,
        Data::Enum(e) => {
            return Err(syn::Error::new_spanned(
                e.enum_token,
                "#[derive(Stats)] supports structs only",
            ));
        }
        Data::Union(u) => {
            return Err(syn::Error::new_spanned(
                u.union_token,
                "#[derive(Stats)] supports structs only",
            ));
        }
    };
    let mut body = Tokens::new();
    let members: Vec<(syn::Member, &syn::Field)> = match fields {
        Fields::Named(n) => n
            .named
            .iter()
            .map(|f| (syn::Member::Named(f.ident.clone().expect("named")), f))
            .collect(),
        Fields::Unnamed(u) => u
            .unnamed
            .iter()
            .enumerate()
            .map(|(i, f)| (syn::Member::Unnamed(i.into()), f))
            .collect(),
        Fields::Unit => Vec::new(),
    };
    for (member, field) in members {
        let merge = field_merge(field)?;
        let a = quote!((&mut self.#member));
        let b = quote!((&other.#member));
        body.extend(merge_code(&field.ty, a, b, merge, 0));
    }
    let (impl_g, ty_g, where_c) = input.generics.split_for_impl();
    Ok(quote! {
        impl #impl_g ::core::ops::AddAssign<&#name #ty_g> for #name #ty_g #where_c {
            #[allow(clippy::needless_borrow, clippy::op_ref)]
            fn add_assign(&mut self, other: &#name #ty_g) {
                #body
            }
        }
        impl #impl_g ::core::ops::AddAssign<#name #ty_g> for #name #ty_g #where_c {
            fn add_assign(&mut self, other: #name #ty_g) {
                *self += &other;
            }
        }
    })
}

/// The merge named by the field's `#[stats(...)]` attribute (sum when absent).
fn field_merge(field: &syn::Field) -> syn::Result<Merge> {
    let mut merge = Merge::Sum;
    for attr in field.attrs.iter().filter(|a| a.path().is_ident("stats")) {
        attr.parse_nested_meta(|meta| {
            if meta.path.is_ident("max") {
                merge = Merge::Max;
                Ok(())
            } else if meta.path.is_ident("sum") {
                merge = Merge::Sum;
                Ok(())
            } else {
                Err(meta.error("unknown stats attribute; expected `max` or `sum`"))
            }
        })?;
    }
    Ok(merge)
}

/// The element type of `Vec<T>` (also `std::vec::Vec<T>`), if `ty` is one.
fn vec_element(ty: &Type) -> Option<&Type> {
    let Type::Path(p) = ty else { return None };
    if p.qself.is_some() {
        return None;
    }
    let last = p.path.segments.last()?;
    if last.ident != "Vec" {
        return None;
    }
    let PathArguments::AngleBracketed(args) = &last.arguments else {
        return None;
    };
    match args.args.first()? {
        GenericArgument::Type(t) if args.args.len() == 1 => Some(t),
        _ => None,
    }
}

/// Code merging place `b: &T` into place `a: &mut T`, recursing into arrays and Vecs.
fn merge_code(ty: &Type, a: Tokens, b: Tokens, merge: Merge, depth: usize) -> Tokens {
    let (x, y) = (format_ident!("__a{depth}"), format_ident!("__b{depth}"));
    match ty {
        Type::Paren(p) => merge_code(&p.elem, a, b, merge, depth),
        Type::Group(g) => merge_code(&g.elem, a, b, merge, depth),
        Type::Array(arr) => {
            let inner = merge_code(&arr.elem, quote!(#x), quote!(#y), merge, depth + 1);
            quote! {
                for (#x, #y) in ::core::iter::Iterator::zip(#a.iter_mut(), #b.iter()) {
                    #inner
                }
            }
        }
        _ => {
            if let Some(elem) = vec_element(ty) {
                let inner = merge_code(elem, quote!(#x), quote!(#y), merge, depth + 1);
                quote! {
                    {
                        let (__dst, __src) = (#a, #b);
                        if __dst.len() < __src.len() {
                            __dst.resize_with(__src.len(), ::core::default::Default::default);
                        }
                        for (#x, #y) in ::core::iter::Iterator::zip(__dst.iter_mut(), __src.iter()) {
                            #inner
                        }
                    }
                }
            } else {
                match merge {
                    Merge::Sum => quote! { *#a += #b; },
                    Merge::Max => quote! {
                        {
                            let (__dst, __src) = (#a, #b);
                            if *__src > *__dst {
                                *__dst = ::core::clone::Clone::clone(__src);
                            }
                        }
                    },
                }
            }
        }
    }
}
