//! gradtac
